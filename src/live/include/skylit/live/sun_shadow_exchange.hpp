#pragma once
// The sun's shadow maps, drawn on one thread and used on another without the user ever waiting
// for one to be drawn (docs/live.md, "The sun's shadow map off the render thread").
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/geom/plane.hpp"
#include "skylit/gpu/gl.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::live {

class SunShadowExchange;

// A finished map, handed from the thread that drew it to the thread that uses it. Held through
// SunShadowHandle; its slot goes back to the pool when the last handle goes.
class SunShadowFrame {
 public:
  SunShadowFrame(const SunShadowFrame&) = delete;
  SunShadowFrame& operator=(const SunShadowFrame&) = delete;
  ~SunShadowFrame();

  // The map (const: the user binds and samples it, and may read it back). std::logic_error
  // after the producer destroyed the maps.
  const render::SunShadowMap& map() const;
  const Eigen::Vector3d& direction() const { return sources_.front().direction; }  // towards source 0 (the sun), unit
  double angular_radius() const { return sources_.front().angular_radius; }
  // Every source drawn, in the map's layer order (directions unit).
  const std::vector<render::ShadowSource>& sources() const { return sources_; }
  // V of each source at every mesh vertex (SunShadowMap::read_vertex_visibility), read once by
  // the producer after the map was complete, for the compositor's lamps.
  const std::vector<std::vector<float>>& vertex_visibility() const { return vertex_visibility_; }
  std::uint64_t sequence() const { return sequence_; }             // 1 for the first map drawn
  // On the user's thread, its context current: its later GL commands wait for the producer's
  // (glWaitSync on the producer's fence). Call before the first use of the map in that context.
  void wait() const;

 private:
  friend class SunShadowExchange;
  SunShadowFrame(SunShadowExchange& exchange, int slot, std::vector<render::ShadowSource> sources,
                 std::vector<std::vector<float>> vertex_visibility, std::uint64_t sequence)
      : exchange_(exchange), slot_(slot), sources_(std::move(sources)), vertex_visibility_(std::move(vertex_visibility)),
        sequence_(sequence) {}

  SunShadowExchange& exchange_;
  int slot_;
  std::vector<render::ShadowSource> sources_;
  std::vector<std::vector<float>> vertex_visibility_;
  std::uint64_t sequence_;
};

using SunShadowHandle = std::shared_ptr<const SunShadowFrame>;

// The producer (the sky thread, in a GL context of its own that shares objects with the render
// thread's: HeadlessContext(ShareGroup)) draws each new sun into a map of a small pool, waits for
// it to be complete and hands it over (in the sky thread's SkyState, a latest-value mailbox); the
// user (the render thread) keeps drawing with the map it has until the next one comes, then
// switches:
//
//   producer (its context current)          user (its context current)
//   frame = exchange.draw(sun, radius)      if (fresh != current) {
//     slot: free, and the user's commands     fresh->wait();              // glWaitSync
//     that used it complete (its release      exchange.release(current);  // glFenceSync + glFlush
//     fence, glClientWaitSync)                current = fresh;
//     map.update(); glFenceSync; glFlush;   }
//     glClientWaitSync (complete)           ... current->map().bind(...) ...
//
// A slot is reused only when no handle to it is left and the user's release fence (if it used
// it) has signalled, so a map is never redrawn while a frame still samples it. One owner per GL
// object: the maps are made, redrawn and destroyed in the producer's context; the fences are
// the exchange's, each deleted by the thread that next takes its slot (sync objects are shared).
class SunShadowExchange {
 public:
  // Counts for /status.
  struct Counts {
    std::uint64_t drawn = 0;       // maps drawn by the producer
    std::uint64_t taken = 0;       // maps the user switched to (wait())
    std::uint64_t slot_waits = 0;  // draws that waited for the user to free a slot
  };

  SunShadowExchange() = default;
  ~SunShadowExchange();
  SunShadowExchange(const SunShadowExchange&) = delete;
  SunShadowExchange& operator=(const SunShadowExchange&) = delete;

  // Producer, its context current: makes `slots` maps (at least 2; 3 lets the producer draw the
  // next sun while one map waits in the mailbox and the user draws with another).
  void create(const scene::Mesh& mesh, std::span<const geom::Plane> planes, const render::SunShadowOptions& options = {},
              int slots = 3);
  // Producer, its context current: draws the map for a sun (SunShadowMap::update's arguments)
  // into a free slot (waiting for one while the user holds them all), and returns it complete.
  // Null once closed (nothing drawn). InputError as SunShadowMap::update.
  SunShadowHandle draw(const Eigen::Vector3d& direction, double angular_radius);
  // The same for several separated sources (SunShadowMap::update's; at most the options'
  // max_sources), the sun first when there is one. With `vertex_visibility`, V of every source
  // at the mesh's vertices is read back once the map is complete (the frame holds it).
  SunShadowHandle draw(std::span<const render::ShadowSource> sources, bool vertex_visibility = false);
  // Producer, its context current, at its end: destroys the maps, after the user's commands on
  // them are complete. The user must no longer use any map (handles may outlive this).
  void destroy();

  // User, its context current: it is done with `frame` (its commands so far may still sample
  // it): fences them, and drops the handle. Nothing for a null handle.
  void release(SunShadowHandle& frame);

  // Wakes a producer waiting for a slot; later draws return null.
  void close();
  Counts counts() const;
  bool created() const;

 private:
  friend class SunShadowFrame;
  struct Slot {
    std::unique_ptr<render::SunShadowMap> map;
    bool busy = false;          // drawing, or handles to it are held
    GLsync ready = nullptr;     // the producer's fence after its last draw into the map
    GLsync released = nullptr;  // the user's fence after its last use of the map
  };
  void free_slot(int slot);
  void note_taken();
  const render::SunShadowMap& map_of(int slot) const;
  GLsync ready_fence(int slot) const;

  mutable std::mutex mutex_;
  std::condition_variable slot_freed_;
  std::vector<Slot> slots_;
  bool closed_ = false;
  std::uint64_t sequence_ = 0;
  Counts counts_;
};

}  // namespace skylit::live
