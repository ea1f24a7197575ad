// SunShadowExchange (src/live/src/sun_shadow_exchange.hpp): the sun's shadow map drawn on a
// worker thread, in a context that shares the test's objects, equals the map drawn in the test's
// own context for the same sun; the user keeps drawing with the map it has while the worker
// waits for a map to draw into, and a map is redrawn only after the user released it. Ordering
// is asserted through the exchange's state, never through wall time.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "skylit/live/sun_shadow_exchange.hpp"
#include "../baker/box_scene.hpp"
#include "../support/gl_suite.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/render/sun_shadow_map.hpp"

namespace skylit::live {
namespace {

using baker::test::Box;
using baker::test::direction;
using baker::test::mesh_of;

class SunShadowExchangeTest : public test::GlSuite {};

constexpr double kSunRadius = 0.0047;

// A 2 m cube and a 4 m pole on the ground; a 12 m ground plane and a wall facing south.
scene::Mesh site_mesh() { return mesh_of({Box{{-1, -1, 0}, {1, 1, 2}}, Box{{2.5, -3.2, 0}, {2.8, -2.9, 4}}}); }

std::vector<geom::Plane> site_planes() {
  geom::Plane ground;
  ground.name = "ground";
  ground.origin = geom::Vec3(-6, -6, 0.01);
  ground.u = geom::Vec3(12, 0, 0);
  ground.v = geom::Vec3(0, 12, 0);
  ground.width = 96;
  ground.height = 96;
  geom::Plane wall;
  wall.name = "wall";
  wall.origin = geom::Vec3(-4, 3, 0);
  wall.u = geom::Vec3(8, 0, 0);
  wall.v = geom::Vec3(0, 0, 3);
  wall.width = 64;
  wall.height = 24;
  return {ground, wall};
}

// What the map shows: V of every plane, read back in the calling thread's context.
std::vector<std::vector<float>> visibility_of(const render::SunShadowMap& map) {
  std::vector<std::vector<float>> v;
  for (int j = 0; j < map.plane_count(); ++j) v.push_back(map.read_visibility(j));
  return v;
}

std::vector<std::vector<float>> reference(const Eigen::Vector3d& sun) {
  render::SunShadowMap map(site_mesh(), site_planes());
  map.update(sun, kSunRadius);
  return visibility_of(map);
}

// The largest |a − b| over every texel of every plane; NaN anywhere gives infinity.
double max_difference(const std::vector<std::vector<float>>& a, const std::vector<std::vector<float>>& b) {
  if (a.size() != b.size()) return INFINITY;
  double worst = 0;
  for (std::size_t j = 0; j < a.size(); ++j) {
    if (a[j].size() != b[j].size()) return INFINITY;
    for (std::size_t k = 0; k < a[j].size(); ++k) {
      if (!std::isfinite(a[j][k]) || !std::isfinite(b[j][k])) return INFINITY;
      worst = std::max(worst, static_cast<double>(std::abs(a[j][k] - b[j][k])));
    }
  }
  return worst;
}

// Waits (bounded, so that a failure cannot hang the suite) until `done` holds.
template <typename F>
bool eventually(F done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

TEST_F(SunShadowExchangeTest, AMapDrawnOnAWorkerThreadEqualsOneDrawnHere) {
  const gpu::HeadlessContext::ShareGroup share = gpu::HeadlessContext::current_share_group();
  const scene::Mesh mesh = site_mesh();
  const std::vector<geom::Plane> planes = site_planes();
  const Eigen::Vector3d sun = direction(35, 250);
  SunShadowExchange exchange;
  std::promise<SunShadowHandle> drawn;
  std::promise<void> finished;
  std::string worker_error;
  std::thread worker([&] {
    try {
      const gpu::HeadlessContext context(share);
      exchange.create(mesh, planes);
      drawn.set_value(exchange.draw(sun, kSunRadius));
      finished.get_future().wait();  // the test reads the map back first
      exchange.destroy();
    } catch (const std::exception& e) {
      worker_error = e.what();
      try {
        drawn.set_value(nullptr);
      } catch (...) {
      }
    }
  });
  SunShadowHandle map = drawn.get_future().get();
  if (!map) {
    finished.set_value();
    worker.join();
    FAIL() << worker_error;
  }
  map->wait();
  const std::vector<std::vector<float>> on_worker = visibility_of(map->map());
  const std::vector<std::vector<float>> here = reference(sun);
  int shadowed = 0, lit = 0;
  for (const float v : on_worker[0]) {
    if (v < 0.01f) ++shadowed;
    if (v > 0.99f) ++lit;
  }
  const render::SunShadowSampling a = map->map().sampling();
  render::SunShadowMap local(mesh, planes);
  local.update(sun, kSunRadius);
  const render::SunShadowSampling b = local.sampling();
  exchange.release(map);
  finished.set_value();
  worker.join();
  ASSERT_TRUE(worker_error.empty()) << worker_error;
  // The same commands on the same driver: the same V, texel for texel (tolerance 1e-6).
  EXPECT_LE(max_difference(on_worker, here), 1e-6);
  EXPECT_GT(shadowed, 100) << "the cube's shadow is on the ground";
  EXPECT_GT(lit, 1000);
  EXPECT_TRUE(a.shadow_from_world.isApprox(b.shadow_from_world, 1e-6f));
  EXPECT_FLOAT_EQ(a.texel_m, b.texel_m);
  EXPECT_FLOAT_EQ(a.bias_m, b.bias_m);
  EXPECT_NE(a.depth_texture, b.depth_texture);
  const SunShadowExchange::Counts counts = exchange.counts();
  EXPECT_EQ(counts.drawn, 1u);
  EXPECT_EQ(counts.taken, 1u);
}

// Two maps: the user holds both (one it draws with, one newer it has not switched to yet), so
// the worker's third sun waits; the user's map keeps its sun meanwhile. Once the user switches
// and releases its old map, the worker redraws that one for the third sun, and the map the user
// now holds is untouched. close() wakes a worker that waits.
TEST_F(SunShadowExchangeTest, TheUserKeepsItsMapWhileTheWorkerWaitsForOne) {
  const gpu::HeadlessContext::ShareGroup share = gpu::HeadlessContext::current_share_group();
  const scene::Mesh mesh = site_mesh();
  const std::vector<geom::Plane> planes = site_planes();
  const Eigen::Vector3d sun_a = direction(35, 250), sun_b = direction(50, 200), sun_c = direction(20, 120);
  SunShadowExchange exchange;
  std::promise<SunShadowHandle> first, second, third;
  std::atomic<bool> third_drawn{false};
  std::atomic<bool> fourth_refused{false};
  std::string worker_error;
  std::thread worker([&] {
    bool handed[3] = {false, false, false};
    try {
      const gpu::HeadlessContext context(share);
      exchange.create(mesh, planes, {}, 2);
      first.set_value(exchange.draw(sun_a, kSunRadius));
      handed[0] = true;
      second.set_value(exchange.draw(sun_b, kSunRadius));
      handed[1] = true;
      SunShadowHandle c = exchange.draw(sun_c, kSunRadius);  // waits: the user holds both maps
      third_drawn = true;
      third.set_value(std::move(c));
      handed[2] = true;
      // Both maps held again (the second and the third): this one waits until close().
      fourth_refused = exchange.draw(sun_a, kSunRadius) == nullptr;
      exchange.destroy();
    } catch (const std::exception& e) {
      worker_error = e.what();
      std::promise<SunShadowHandle>* promises[3] = {&first, &second, &third};
      for (int k = 0; k < 3; ++k) {
        if (!handed[k]) promises[k]->set_value(nullptr);
      }
    }
  });
  SunShadowHandle a = first.get_future().get();
  SunShadowHandle b = second.get_future().get();
  if (!a || !b) {
    exchange.close();
    worker.join();
    FAIL() << worker_error;
  }
  a->wait();
  // The worker now waits for a map; the user keeps drawing with its own, for its own sun.
  ASSERT_TRUE(eventually([&] { return exchange.counts().slot_waits == 1; }));
  const std::vector<std::vector<float>> ref_a = reference(sun_a);
  for (int frame = 0; frame < 3; ++frame) {
    EXPECT_LE(max_difference(visibility_of(a->map()), ref_a), 1e-6) << "frame " << frame;
    EXPECT_FALSE(third_drawn) << "a map was redrawn while the user held it";
  }
  // The user switches to the newer map and releases its old one: the worker draws the third sun
  // into the released map, never into the one the user now holds.
  b->wait();
  exchange.release(a);
  SunShadowHandle c = third.get_future().get();
  ASSERT_TRUE(c) << worker_error;
  EXPECT_TRUE(third_drawn);
  c->wait();
  EXPECT_EQ(c->sequence(), 3u);
  EXPECT_LE(max_difference(visibility_of(b->map()), reference(sun_b)), 1e-6);
  EXPECT_LE(max_difference(visibility_of(c->map()), reference(sun_c)), 1e-6);
  EXPECT_GT(max_difference(reference(sun_b), reference(sun_c)), 0.5) << "the suns give different shadows";
  // The worker waits for a map again; close() wakes it with nothing drawn. The user is done
  // with both maps (glFinish: its commands on them are complete) before the worker destroys them.
  ASSERT_TRUE(eventually([&] { return exchange.counts().slot_waits == 2; }));
  glFinish();
  exchange.close();
  worker.join();
  b.reset();
  c.reset();
  ASSERT_TRUE(worker_error.empty()) << worker_error;
  EXPECT_TRUE(fourth_refused);
  const SunShadowExchange::Counts counts = exchange.counts();
  EXPECT_EQ(counts.drawn, 3u);
  EXPECT_EQ(counts.taken, 3u);
}

}  // namespace
}  // namespace skylit::live
