// The service under faults: a sky or camera folder that disappears mid-run, malformed frames, a
// full disk under the recording, a bake made for another site, a bad config field; and its
// status over HTTP while it runs.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "../support/promtool.hpp"
#include "live_fixture.hpp"
#include "skylit/base/error.hpp"
#include "skylit/live/frame_log.hpp"
// After Eigen: httplib brings <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>

namespace skylit::live_test {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

TEST(ServiceFaults, ASkyFolderThatDisappearsLeavesTheLastSkyFlaggedStale) {
  RigOptions rig_options;
  rig_options.sky_frames = 2;
  rig_options.sky_loop = true;
  rig_options.sky_realtime = "1";  // a sky frame every 0.5 s
  rig_options.stale_after = 1.0;
  const Rig rig(rig_options);
  RunningService running(rig.config(), quiet_options());
  ASSERT_TRUE(running.wait_for([](const json& s) { return s["sky"]["estimates"].get<int>() >= 2 && frames_of(s) >= 3; }))
      << running.error() << running.status().dump(2);
  EXPECT_FALSE(has_flag(running.status(), "sky_stale"));

  fs::remove_all(rig.dir() / "sky");
  const auto gone = std::chrono::steady_clock::now();
  // The frame read ahead and held for its time (realtime pacing) still comes, 0.5 s later; once
  // no estimate has come for stale_after the sky is flagged stale, and S changes no more.
  ASSERT_TRUE(running.wait_for([](const json& s) { return has_flag(s, "sky_stale"); }, 20)) << running.status().dump(2);
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - gone).count();
  const json before = running.status();
  ASSERT_TRUE(running.wait_for([&](const json& s) { return frames_of(s) > frames_of(before); }, 20))
      << running.error() << running.status().dump(2);
  const json after = running.status();
  std::printf("measured: sky_stale %.2f s after the folder went (stale_after 1 s); %lld sky files unreadable\n",
              waited, static_cast<long long>(after["sky"]["malformed"].get<std::int64_t>()));

  // The service runs on with the last sky: frames keep coming, S is the one from before.
  EXPECT_FALSE(running.done()) << running.error();
  EXPECT_GT(frames_of(after), frames_of(before));
  ASSERT_TRUE(after["sky"].contains("S"));
  EXPECT_EQ(after["sky"]["S"], before["sky"]["S"]);
  EXPECT_EQ(after["sky"]["estimates"], before["sky"]["estimates"]);
  EXPECT_GE(after["sky"]["age_s"].get<double>(), 1.0);
  // The files it then tries are counted as unreadable, unless the source was caught between
  // reading an image and its metadata: then it is down and reopened with backoff (the folder is
  // gone, so it stays down). Either way the service runs on.
  EXPECT_NE(running.service().metrics_text().find("skylit_flag{flag=\"sky_stale\"} 1"), std::string::npos);
  running.finish();
  EXPECT_TRUE(running.error().empty()) << running.error();
}

TEST(ServiceFaults, ACameraFolderThatDisappearsAndComesBackResumes) {
  RigOptions rig_options;
  // Silent for 0.5 s: taken as failed and reopened, after 0.1 s, then every 0.2 s.
  rig_options.camera_source_extra = "    reconnect: {initial: 0.1, max: 0.2, silence: 0.5}\n";
  const Rig rig(rig_options);
  RunningService running(rig.config(), quiet_options());
  ASSERT_TRUE(running.wait_for([](const json& s) { return frames_of(s) >= 5; })) << running.error();
  const json before = running.status();
  EXPECT_EQ(before["camera"]["state"], "running") << before["camera"].dump(2);
  EXPECT_EQ(before["camera"]["reconnect_attempts"], 0);
  EXPECT_EQ(before["camera"]["last_error"], "");
  EXPECT_LT(before["camera"]["seconds_since_frame"].get<double>(), 0.5);

  fs::remove_all(rig.dir() / "camera");
  const std::int64_t frames_gone = frames_of(running.status());

  // The source is reported down, reopened with backoff, each attempt failing on the missing folder.
  ASSERT_TRUE(running.wait_for([](const json& s) {
    return s["camera"]["state"] == "reconnecting" && s["camera"]["reconnect_attempts"].get<int>() >= 2;
  }, 10)) << running.status().dump(2);
  const json down = running.status();
  // Nothing new to composite since the folder went: at most the frame read ahead and the one in flight.
  EXPECT_LE(frames_of(down), frames_gone + 2);
  EXPECT_FALSE(running.done()) << running.error();
  std::printf("measured: camera down: %s\n", down["camera"].dump().c_str());
  EXPECT_NE(down["camera"]["last_error"].get<std::string>().find("camera"), std::string::npos) << down["camera"].dump(2);
  EXPECT_GE(down["camera"]["seconds_since_frame"].get<double>(), 0.5);
  EXPECT_TRUE(has_flag(down, "camera_reconnecting")) << down.dump(2);
  const std::string metrics = running.service().metrics_text();
  EXPECT_NE(metrics.find("skylit_source_state{source=\"camera\",state=\"reconnecting\"} 1"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("skylit_source_state{source=\"camera\",state=\"running\"} 0"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("skylit_source_reconnect_attempts_total{source=\"camera\"} "), std::string::npos) << metrics;

  // The files come back (a remounted disk): frames flow again.
  write_frames(rig.dir() / "camera", rig.camera_frames(), 30, "png");
  ASSERT_TRUE(running.wait_for([&](const json& s) { return frames_of(s) >= frames_of(down) + 5; }, 20))
      << running.status().dump(2);
  const json back = running.status();
  EXPECT_EQ(back["camera"]["state"], "running") << back["camera"].dump(2);
  EXPECT_GE(back["camera"]["reconnects"].get<int>(), 1);
  EXPECT_GT(back["camera"]["reconnect_attempts"].get<int>(), back["camera"]["reconnects"].get<int>());
  EXPECT_FALSE(has_flag(back, "camera_reconnecting"));
  const auto stop_asked = std::chrono::steady_clock::now();
  running.finish();
  EXPECT_LT(std::chrono::steady_clock::now() - stop_asked, 5s);
  EXPECT_TRUE(running.error().empty()) << running.error();
}

TEST(ServiceFaults, MalformedFramesAreDroppedAndCountedInTheStatus) {
  RigOptions rig_options;
  rig_options.camera_frames = 6;
  rig_options.camera_loop = false;
  rig_options.status = "127.0.0.1:0";
  const Rig rig(rig_options);
  // Frame 2 has the wrong size, frame 4 is not an image at all (a file cut short).
  cv::imwrite((rig.dir() / "camera" / "frame_0002.png").string(), camera_frame(80, 60, 2));
  std::ofstream(rig.dir() / "camera" / "frame_0004.png") << "\x89PNG cut short";

  RunningService running(rig.config(), quiet_options());
  const std::int64_t frames = running.join();  // the recording ends
  ASSERT_TRUE(running.error().empty()) << running.error();
  EXPECT_GE(frames, 1);

  // /status answers after the run, too (the server lives as long as the service).
  const std::string address = running.service().status_address();
  httplib::Client client("127.0.0.1", std::stoi(address.substr(address.rfind(':') + 1)));
  const auto response = client.Get("/status");
  ASSERT_TRUE(response);
  const json status = json::parse(response->body);
  EXPECT_EQ(status["camera"]["malformed"].get<int>(), 2) << status.dump(2);
  EXPECT_EQ(status["camera"]["frames"].get<int>(), 4) << status.dump(2);
  EXPECT_EQ(status["frames"].get<std::int64_t>(), frames);
}

// A small tmpfs mounted over `dir` while it lives (root only: mounted() is false otherwise).
class SmallDisk {
 public:
  SmallDisk(const fs::path& dir, int megabytes) : dir_(dir) {
    fs::create_directories(dir);
    const std::string command = "mount -t tmpfs -o size=" + std::to_string(megabytes) + "m tmpfs '" + dir.string() + "' 2>/dev/null";
    mounted_ = std::system(command.c_str()) == 0;
  }
  ~SmallDisk() {
    if (mounted_) (void)std::system(("umount '" + dir_.string() + "'").c_str());
  }
  SmallDisk(const SmallDisk&) = delete;
  SmallDisk& operator=(const SmallDisk&) = delete;
  bool mounted() const { return mounted_; }
  // Writes `file` until the disk refuses more.
  void fill(const fs::path& file) const {
    std::FILE* out = std::fopen(file.c_str(), "wb");
    ASSERT_NE(out, nullptr);
    const std::vector<char> block(64 * 1024, 'x');
    while (std::fwrite(block.data(), 1, block.size(), out) == block.size() && std::fflush(out) == 0) {
    }
    std::fclose(out);
  }

 private:
  fs::path dir_;
  bool mounted_ = false;
};

// The disk for recordings fills and is freed: the service runs on, flags `recording_failing`
// while frames are lost, and records again after; the recording holds exactly the frames its log
// lists. For a folder of PNGs and for a video (whose writer reports no failure of its own).
TEST(ServiceFaults, ARecordingOnAFullDiskIsFlaggedWhileItLastsAndResumes) {
  for (const std::string record : {"frames", "live.avi"}) {
    SCOPED_TRACE(record);
    RigOptions rig_options;
    const test::TempDir disk_root("skylit_small_disk_");
    const fs::path disk_dir = disk_root / "disk";
    rig_options.extra = "output:\n  record: {path: " + (disk_dir / record).string() + ", fps: 30}\n";
    const Rig rig(rig_options);
    const SmallDisk disk(disk_dir, 4);
    if (!disk.mounted()) GTEST_SKIP() << "mounting a tmpfs needs root: the full disk is tested by root only";
    std::int64_t frames = 0;
    {
      RunningService running(rig.config(), quiet_options());
      const auto written = [](const json& s) { return s["recording"]["written"].get<std::int64_t>(); };
      ASSERT_TRUE(running.wait_for([&](const json& s) { return s.contains("recording") && written(s) >= 5; }))
          << running.error() << running.status().dump(2);
      disk.fill(disk_dir / "filler");
      ASSERT_TRUE(running.wait_for([](const json& s) { return has_flag(s, "recording_failing"); }, 20))
          << running.status().dump(2);
      const json full = running.status();
      ASSERT_TRUE(running.wait_for([&](const json& s) { return s["recording"]["lost"].get<std::int64_t>() >= 5; }, 20));
      EXPECT_FALSE(running.done()) << running.error();
      const std::string error = full["recording"]["last_error"].get<std::string>();
      EXPECT_NE(error.find((disk_dir / record).string()), std::string::npos) << error;
      std::printf("measured: %s on a full disk: %s\n", record.c_str(), full["recording"].dump().c_str());
      EXPECT_NE(running.service().metrics_text().find("skylit_recording_frames_lost_total "), std::string::npos);

      fs::remove(disk_dir / "filler");
      ASSERT_TRUE(running.wait_for([&](const json& s) { return !has_flag(s, "recording_failing") && written(s) >= written(full) + 5; }, 20))
          << running.status().dump(2);
      running.finish();
      EXPECT_TRUE(running.error().empty()) << running.error();
      const json end = running.status();
      frames = written(end);
      EXPECT_EQ(frames + end["recording"]["lost"].get<std::int64_t>(), end["frames"].get<std::int64_t>()) << end.dump(2);
    }
    // Every frame the log lists is in the recording, and only those.
    const fs::path log = record == "frames" ? disk_dir / "frames" / "frames.csv" : disk_dir / "live.csv";
    EXPECT_EQ(static_cast<std::int64_t>(live::read_frame_log(log).size()), frames);
    if (record == "frames") {
      std::int64_t images = 0;
      for (const auto& entry : fs::directory_iterator(disk_dir / "frames")) images += entry.path().extension() == ".png";
      EXPECT_EQ(images, frames);
    } else {
      cv::VideoCapture video((disk_dir / record).string());
      ASSERT_TRUE(video.isOpened());
      std::int64_t decoded = 0;
      for (cv::Mat image; video.read(image);) ++decoded;
      EXPECT_EQ(decoded, frames);
    }
  }
}

TEST(ServiceFaults, ABakeMadeForAnotherSiteRefusesToStartNamingTheDifferences) {
  const Rig rig;
  const BakedSite& baked = BakedSite::get();
  // The baked site, but on a finer dome, with a coarser ground and a renamed wall.
  std::ofstream(rig.dir() / "other_site.yaml")
      << "root: /\nscene:\n  model: " << quoted(baked.dir / "tower.glb") << "\n  up: y\n  scale: 1\n"
      << "dome:\n  frequency: 4\n"
      << "planes:\n"
      << "  - name: ground\n    origin: [-8, -8, 0.01]\n    u: [16, 0, 0]\n    v: [0, 16, 0]\n"
      << "    resolution: [64, 64]\n    surface: real\n"
      << "  - name: roof\n    origin: [-1, -1, 4.01]\n    u: [2, 0, 0]\n    v: [0, 2, 0]\n    resolution: [16, 16]\n"
      << "  - name: facade\n    origin: [-1, -1.01, 0]\n    u: [2, 0, 0]\n    v: [0, 0, 4]\n    resolution: [16, 32]\n";
  live::LiveConfig config = rig.config();
  config.site = rig.dir() / "other_site.yaml";
  try {
    const live::Service service(config, quiet_options());
    FAIL() << "the service started on a bake made for another site";
  } catch (const InputError& e) {
    const std::string message = e.what();
    std::printf("measured: %s\n", message.c_str());
    EXPECT_NE(message.find("dome frequency: bake 2, site 4"), std::string::npos) << message;
    EXPECT_NE(message.find("plane 0 'ground': resolution 128×128 in the bake, 64×64 in the site"), std::string::npos) << message;
    EXPECT_NE(message.find("plane 2 'facade': the bake's is named 'wall'"), std::string::npos) << message;
    EXPECT_EQ(message.find("'roof'"), std::string::npos) << message;  // the roof agrees
    EXPECT_NE(message.find("Fix: bake again (skylit-bake " + config.site.string()), std::string::npos) << message;
  }
}

TEST(ServiceFaults, ABadConfigFieldNamesTheFileLineAndField) {
  const Rig rig;
  struct Case {
    std::string yaml;     // appended to the rig's config
    std::string field;    // what the message must name
    std::string detail;   // and this
  };
  const std::vector<Case> cases{
      {"blend:\n  storage: float16\n", "blend.storage", "half"},
      {"output:\n  window: maybe\n", "output.window", "true or false"},
      {"status:\n  lisen: 127.0.0.1:0\n", "lisen", "did you mean 'listen'"},
      {"blend:\n  device: fpga\n", "blend.device", "cpu"},
      {"blend: vulkan\n", "blend", "gpu"},
      {"output:\n  record: {path: out.mp4, fps: 0}\n", "output.record.fps", "frames per second"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.field);
    const std::string text = rig.config_text();
    const fs::path file = rig.dir() / "bad.yaml";
    std::ofstream(file) << text << c.yaml;
    // The offending line: the last line of the appended text holds the bad value.
    const int line = static_cast<int>(std::count(text.begin(), text.end(), '\n') +
                                      std::count(c.yaml.begin(), c.yaml.end(), '\n'));
    try {
      (void)live::load_live_config(file);
      FAIL() << "a bad field was accepted";
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(file.string() + ":" + std::to_string(line) + ":"), std::string::npos) << message;
      EXPECT_NE(message.find(c.field), std::string::npos) << message;
      EXPECT_NE(message.find(c.detail), std::string::npos) << message;
    }
  }
}

TEST(ServiceStatus, StatusAndMetricsOverHttpWhileRunning) {
  RigOptions rig_options;
  rig_options.status = "127.0.0.1:0";  // any free port
  const Rig rig(rig_options);
  RunningService running(rig.config(), quiet_options());
  ASSERT_TRUE(running.wait_for([](const json& s) { return frames_of(s) >= 3 && s["state"] == "running"; }))
      << running.error();
  const std::string address = running.service().status_address();
  const int port = std::stoi(address.substr(address.rfind(':') + 1));
  ASSERT_GT(port, 0) << address;
  httplib::Client client("127.0.0.1", port);

  const auto first = client.Get("/status");
  ASSERT_TRUE(first);
  EXPECT_EQ(first->status, 200);
  EXPECT_EQ(first->get_header_value("Content-Type"), "application/json");
  const json status = json::parse(first->body);
  EXPECT_GE(status["frames"].get<int>(), 3);
  // Camera frame received to composite done: at least a frame's drawing, far under a second.
  EXPECT_GT(status["latency_ms"]["p50"].get<double>(), 0.0) << status.dump(2);
  EXPECT_LE(status["latency_ms"]["p50"].get<double>(), status["latency_ms"]["p99"].get<double>());
  EXPECT_LT(status["latency_ms"]["p99"].get<double>(), 1000.0);
  EXPECT_EQ(status["sky"]["S"].size(), BakedSite::get().manifest.layer_count());
  EXPECT_FALSE(status["sky"]["sun"].is_null());
  EXPECT_NEAR(status["sky"]["sun"]["elevation_deg"].get<double>(), kSunElevationDeg, 1.0);
  // An HDR sky's sun: its own peak, measured, nothing clipped or corrected.
  EXPECT_EQ(status["sky"]["sun"]["located_by"], "peak");
  EXPECT_EQ(status["sky"]["sun"]["energy_estimator"], "measured");
  EXPECT_DOUBLE_EQ(status["sky"]["sun"]["energy_confidence"].get<double>(), 1.0);
  EXPECT_FALSE(status["sky"]["sun"]["colour_corrected"].get<bool>());
  EXPECT_TRUE(status["flags"].empty()) << status.dump(2);
  EXPECT_NE(status["camera"]["source"].get<std::string>().find("images"), std::string::npos);
  EXPECT_EQ(status["camera"]["state"], "running");
  EXPECT_NEAR(status["camera"]["frame_rate_hz"].get<double>(), 30.0, 0.01);  // the rig films at 30 frames/s
  EXPECT_EQ(status["state"], "running");
  // The memory a leak would grow: the heap the program holds, within what malloc keeps, within
  // what is resident.
  const json& memory = status["memory"];
  EXPECT_GT(memory["heap_in_use_bytes"].get<double>(), 1e6) << memory.dump();
  EXPECT_GE(memory["heap_held_bytes"].get<double>(), memory["heap_in_use_bytes"].get<double>()) << memory.dump();
  EXPECT_GT(memory["resident_bytes"].get<double>(), 1e6) << memory.dump();
  // blend.device auto: the CPU on a software GL renderer (llvmpipe), the GPU on a real one.
  EXPECT_EQ(status["blend"]["setting"], "auto");
  EXPECT_EQ(status["blend"]["device"], status["blend"]["software_renderer"].get<bool>() ? "cpu" : "gpu")
      << status["blend"].dump();
  // The rig's sky is one frame, read once: that source has ended (its S stays).
  ASSERT_TRUE(running.wait_for([](const json& s) { return s["sky"]["state"] == "ended"; }, 10)) << running.status().dump(2);

  const auto metrics = client.Get("/metrics");
  ASSERT_TRUE(metrics);
  EXPECT_EQ(metrics->status, 200);
  for (const std::string expected :
       {"# TYPE skylit_frames_total counter\nskylit_frames_total ", "# TYPE skylit_frame_time_seconds summary\n",
        "skylit_frame_time_seconds{quantile=\"0.99\"} ", "skylit_frame_time_seconds_count ", "skylit_sky_luminance{layer=\"0\",channel=\"r\"} ",
        "skylit_sun_detected 1\n", "skylit_sky_age_seconds ", "skylit_waiting_for_sky 0\n",
        "skylit_source_state{source=\"sky\",state=\"ended\"} 1\n", "skylit_source_seconds_since_frame{source=\"camera\"} ",
        "# TYPE skylit_heap_in_use_bytes gauge\nskylit_heap_in_use_bytes ", "# TYPE process_resident_memory_bytes gauge\n"}) {
    EXPECT_NE(metrics->body.find(expected), std::string::npos) << expected << "\n" << metrics->body;
  }
  // Prometheus' own tool accepts them (a quantile belongs to a summary, not a gauge).
  EXPECT_EQ(test::promtool_problems(metrics->body), "") << metrics->body;

  const auto frame = client.Get("/frame.jpg");
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->status, 200);
  const cv::Mat decoded = cv::imdecode(std::vector<std::uint8_t>(frame->body.begin(), frame->body.end()), cv::IMREAD_COLOR);
  EXPECT_EQ(decoded.size(), cv::Size(96, 72));
  ASSERT_TRUE(running.wait_for([&](const json&) {
    const auto sky = client.Get("/sky.jpg");
    return sky && sky->status == 200;
  }, 10));

  // A second look: the counters move while it runs.
  ASSERT_TRUE(running.wait_for([&](const json& s) { return frames_of(s) > status["frames"].get<std::int64_t>() + 3; }, 20));
  const auto second = client.Get("/status");
  ASSERT_TRUE(second);
  EXPECT_GT(json::parse(second->body)["frames"].get<int>(), status["frames"].get<int>());

  // The console's plots start from the node's own samples (one a second, the sky's mean S among
  // them), and its map from the site's planes.
  ASSERT_TRUE(running.wait_for([&](const json&) {
    const auto history = client.Get("/history.json");
    if (!history || history->status != 200) return false;
    const json samples = json::parse(history->body)["samples"];
    return samples.size() >= 2 && samples.back()["S"].size() == 3 && samples.back()["frame_ms"].is_number();
  }, 20)) << client.Get("/history.json")->body;
  const auto map = client.Get("/map.json");
  ASSERT_TRUE(map);
  const json site_map = json::parse(map->body);
  ASSERT_EQ(site_map["planes"].size(), BakedSite::get().manifest.planes.size()) << map->body;
  EXPECT_EQ(site_map["planes"][0]["corners"].size(), 4u);
  EXPECT_TRUE(site_map["tags"].empty());  // a fixed pose: no marker map
}

}  // namespace
}  // namespace skylit::live_test
