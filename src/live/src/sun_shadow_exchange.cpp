// Sun shadow maps drawn on one thread and used on another (see sun_shadow_exchange.hpp).
#include "skylit/live/sun_shadow_exchange.hpp"

#include <stdexcept>
#include <string>
#include <utility>

namespace skylit::live {
namespace {

// Waits on the calling thread until `fence` has signalled (the commands before it are complete).
void client_wait(GLsync fence, const char* what) {
  if (fence == nullptr) return;
  constexpr GLuint64 kSecond = 1'000'000'000;
  for (;;) {
    const GLenum result = glClientWaitSync(fence, GL_SYNC_FLUSH_COMMANDS_BIT, kSecond);
    if (result == GL_ALREADY_SIGNALED || result == GL_CONDITION_SATISFIED) return;
    if (result == GL_WAIT_FAILED) {
      throw gpu::GlError(std::string("sun shadow exchange: glClientWaitSync failed on ") + what);
    }
  }
}

void delete_fence(GLsync& fence) {
  if (fence != nullptr) glDeleteSync(fence);
  fence = nullptr;
}

}  // namespace

SunShadowFrame::~SunShadowFrame() { exchange_.free_slot(slot_); }

const render::SunShadowMap& SunShadowFrame::map() const { return exchange_.map_of(slot_); }

void SunShadowFrame::wait() const {
  if (const GLsync fence = exchange_.ready_fence(slot_); fence != nullptr) glWaitSync(fence, 0, GL_TIMEOUT_IGNORED);
  exchange_.note_taken();
}

SunShadowExchange::~SunShadowExchange() = default;

void SunShadowExchange::create(const scene::Mesh& mesh, std::span<const geom::Plane> planes,
                               const render::SunShadowOptions& options, int slots) {
  if (slots < 2) throw std::logic_error("sun shadow exchange: at least 2 slots");
  std::vector<Slot> made(static_cast<std::size_t>(slots));
  for (Slot& slot : made) slot.map = std::make_unique<render::SunShadowMap>(mesh, planes, options);
  std::lock_guard lock(mutex_);
  if (!slots_.empty()) throw std::logic_error("sun shadow exchange: create() twice");
  slots_ = std::move(made);
}

SunShadowHandle SunShadowExchange::draw(const Eigen::Vector3d& direction, double angular_radius) {
  const render::ShadowSource sun{direction, angular_radius};
  return draw(std::span<const render::ShadowSource>(&sun, 1));
}

SunShadowHandle SunShadowExchange::draw(std::span<const render::ShadowSource> sources, bool vertex_visibility) {
  std::vector<std::vector<float>> vertex_values;
  int chosen = -1;
  GLsync released = nullptr;
  GLsync ready = nullptr;
  std::uint64_t sequence = 0;
  {
    std::unique_lock lock(mutex_);
    if (slots_.empty()) throw std::logic_error("sun shadow exchange: draw() before create()");
    const auto find_free = [&] {
      for (std::size_t k = 0; k < slots_.size(); ++k) {
        if (!slots_[k].busy) return static_cast<int>(k);
      }
      return -1;
    };
    chosen = find_free();
    if (chosen < 0 && !closed_) {
      ++counts_.slot_waits;
      slot_freed_.wait(lock, [&] { return closed_ || (chosen = find_free()) >= 0; });
    }
    if (closed_) return nullptr;
    Slot& slot = slots_[static_cast<std::size_t>(chosen)];
    slot.busy = true;
    released = std::exchange(slot.released, nullptr);
    ready = std::exchange(slot.ready, nullptr);
    sequence = ++sequence_;
  }
  // From here the slot is this thread's alone until the handle is made.
  try {
    client_wait(released, "the user's last use of a map");  // no frame samples the map any more
    delete_fence(released);
    delete_fence(ready);
    render::SunShadowMap& map = *slots_[static_cast<std::size_t>(chosen)].map;
    map.update(sources);
    GLsync fence = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    glFlush();
    client_wait(fence, "drawing a map");  // complete before it is handed over
    if (vertex_visibility) {
      for (int k = 0; k < map.source_count(); ++k) vertex_values.push_back(map.read_vertex_visibility(k));
    }
    gpu::check_gl_error("sun shadow exchange: drawing a map");
    std::lock_guard lock(mutex_);
    slots_[static_cast<std::size_t>(chosen)].ready = fence;
    ++counts_.drawn;
  } catch (...) {
    delete_fence(released);
    free_slot(chosen);
    throw;
  }
  std::vector<render::ShadowSource> drawn(sources.begin(), sources.end());
  for (render::ShadowSource& source : drawn) source.direction.normalize();
  return SunShadowHandle(new SunShadowFrame(*this, chosen, std::move(drawn), std::move(vertex_values), sequence));
}

void SunShadowExchange::release(SunShadowHandle& frame) {
  if (!frame) return;
  GLsync fence = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
  glFlush();  // the producer's wait on the fence must not depend on this context flushing later
  {
    std::lock_guard lock(mutex_);
    GLsync& released = slots_[static_cast<std::size_t>(frame->slot_)].released;
    if (released != nullptr) glDeleteSync(released);  // an earlier release of the same map: this one is later
    released = fence;
  }
  frame.reset();
}

void SunShadowExchange::destroy() {
  std::vector<Slot> slots;
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
    // The bookkeeping stays (handles may still come back); the maps and fences go.
    for (Slot& slot : slots_) {
      Slot taken;
      taken.map = std::move(slot.map);
      taken.released = std::exchange(slot.released, nullptr);
      taken.ready = std::exchange(slot.ready, nullptr);
      slots.push_back(std::move(taken));
    }
  }
  slot_freed_.notify_all();
  for (Slot& slot : slots) {
    client_wait(slot.released, "the user's last use of a map");
    delete_fence(slot.released);
    delete_fence(slot.ready);
    slot.map.reset();
  }
}

void SunShadowExchange::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  slot_freed_.notify_all();
}

SunShadowExchange::Counts SunShadowExchange::counts() const {
  std::lock_guard lock(mutex_);
  return counts_;
}

bool SunShadowExchange::created() const {
  std::lock_guard lock(mutex_);
  return !slots_.empty();
}

void SunShadowExchange::free_slot(int slot) {
  {
    std::lock_guard lock(mutex_);
    slots_[static_cast<std::size_t>(slot)].busy = false;
  }
  slot_freed_.notify_all();
}

void SunShadowExchange::note_taken() {
  std::lock_guard lock(mutex_);
  ++counts_.taken;
}

const render::SunShadowMap& SunShadowExchange::map_of(int slot) const {
  std::lock_guard lock(mutex_);
  const render::SunShadowMap* map = slots_[static_cast<std::size_t>(slot)].map.get();
  if (map == nullptr) throw std::logic_error("sun shadow exchange: the maps were destroyed");
  return *map;
}

GLsync SunShadowExchange::ready_fence(int slot) const {
  std::lock_guard lock(mutex_);
  return slots_[static_cast<std::size_t>(slot)].ready;
}

}  // namespace skylit::live
