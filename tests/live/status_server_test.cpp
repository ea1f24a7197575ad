#include <gtest/gtest.h>
#include <httplib.h>

#include <atomic>
#include <string>

#include "skylit/base/error.hpp"
#include "skylit/live/status_server.hpp"

namespace skylit::live {
namespace {

TEST(StatusServer, AnswersStatusMetricsAndImagesFromItsCallbacks) {
  std::atomic<int> frames = 0;
  StatusHandlers handlers;
  handlers.status_json = [&] { return "{\"frames\": " + std::to_string(frames.load()) + "}"; };
  handlers.metrics_text = [&] {
    return prometheus_text({{"skylit_frames_total", "Frames composited.", "counter", double(frames.load()), ""}});
  };
  handlers.sky_jpeg = [] { return std::vector<std::uint8_t>{}; };
  handlers.frame_jpeg = [] { return std::vector<std::uint8_t>{0xFF, 0xD8, 0xFF, 0xD9}; };
  StatusServer server("127.0.0.1", 0, handlers);
  ASSERT_GT(server.port(), 0);

  httplib::Client client("127.0.0.1", server.port());
  frames = 7;
  auto status = client.Get("/status");
  ASSERT_TRUE(status);
  EXPECT_EQ(status->status, 200);
  EXPECT_EQ(status->body, "{\"frames\": 7}");
  EXPECT_EQ(status->get_header_value("Content-Type"), "application/json");

  auto metrics = client.Get("/metrics");
  ASSERT_TRUE(metrics);
  EXPECT_NE(metrics->body.find("# TYPE skylit_frames_total counter\nskylit_frames_total 7\n"), std::string::npos);

  auto sky = client.Get("/sky.jpg");
  ASSERT_TRUE(sky);
  EXPECT_EQ(sky->status, 503);  // no sky yet
  auto frame = client.Get("/frame.jpg");
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->status, 200);
  EXPECT_EQ(frame->body.size(), 4u);
  EXPECT_EQ(frame->get_header_value("Content-Type"), "image/jpeg");
}

TEST(StatusServer, APortInUseIsAClearError) {
  StatusServer first("127.0.0.1", 0, {});
  try {
    StatusServer second("127.0.0.1", first.port(), {});
    FAIL() << "a second server bound the same port";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(first.address()), std::string::npos) << message;
    EXPECT_NE(message.find("--status"), std::string::npos) << message;
  }
}

TEST(PrometheusText, OneHelpAndTypePerNameAndLabelledSamples) {
  const std::string text = prometheus_text({
      {"skylit_sky_luminance", "Luminance S per face and channel.", "gauge", 0.5, "face=\"0\",channel=\"r\""},
      {"skylit_sky_luminance", "Luminance S per face and channel.", "gauge", 0.25, "face=\"0\",channel=\"g\""},
      {"skylit_sky_age_seconds", "Age of the newest sky.", "gauge", std::numeric_limits<double>::infinity(), ""},
  });
  EXPECT_EQ(text,
            "# HELP skylit_sky_luminance Luminance S per face and channel.\n"
            "# TYPE skylit_sky_luminance gauge\n"
            "skylit_sky_luminance{face=\"0\",channel=\"r\"} 0.5\n"
            "skylit_sky_luminance{face=\"0\",channel=\"g\"} 0.25\n"
            "# HELP skylit_sky_age_seconds Age of the newest sky.\n"
            "# TYPE skylit_sky_age_seconds gauge\n"
            "skylit_sky_age_seconds +Inf\n");
}

TEST(ListenAddress, ParsesAndRejectsWithTheFix) {
  EXPECT_EQ(parse_listen_address("127.0.0.1:8080", "--status"), std::make_pair(std::string("127.0.0.1"), 8080));
  EXPECT_EQ(parse_listen_address("0.0.0.0:0", "--status"), std::make_pair(std::string("0.0.0.0"), 0));
  for (const char* bad : {"8080", ":8080", "localhost:", "host:99999", "host:80x"}) {
    EXPECT_THROW(parse_listen_address(bad, "--status"), InputError) << bad;
  }
}

}  // namespace
}  // namespace skylit::live
