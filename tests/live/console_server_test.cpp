// The console's server side (docs/console.md): the page built into the program, the token that
// guards it off loopback, the bake view, and one JPEG per frame however many pages ask.
#include <gtest/gtest.h>
#include <httplib.h>

#include <atomic>
#include <fstream>
#include <string>

#include <opencv2/core.hpp>

#include "../support/temp_dir.hpp"
#include "skylit/live/jpeg_cache.hpp"
#include "skylit/base/error.hpp"
#include "skylit/live/mailbox.hpp"
#include "skylit/live/status_server.hpp"

namespace skylit::live {
namespace {

StatusHandlers with_status() {
  StatusHandlers handlers;
  handlers.status_json = [] { return std::string("{\"state\": \"running\"}"); };
  handlers.frame_jpeg = [] { return std::vector<std::uint8_t>{0xFF, 0xD8, 0xFF, 0xD9}; };
  handlers.title = "skylit-live test";
  return handlers;
}

TEST(ConsoleServer, ServesThePageItsStyleAndScriptBuiltIn) {
  StatusServer server("127.0.0.1", 0, with_status());
  httplib::Client client("127.0.0.1", server.port());
  const auto page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  for (const char* part : {"id=\"view-sky\"", "id=\"view-hmd\"", "id=\"view-site\"", "id=\"view-bake\"", "id=\"flags\"",
                           "/console.js", "/console.css"}) {
    EXPECT_NE(page->body.find(part), std::string::npos) << part;
  }
  for (const char* file : {"/console.js", "/console.css"}) {
    const auto got = client.Get(file);
    ASSERT_TRUE(got);
    EXPECT_EQ(got->status, 200) << file;
    EXPECT_GT(got->body.size(), 1000u) << file;
  }
  const auto info = client.Get("/console.json");
  ASSERT_TRUE(info);
  EXPECT_EQ(info->body, "{\"title\": \"skylit-live test\", \"site\": false, \"frame\": true, \"bake\": false, \"map\": false}");
  EXPECT_EQ(client.Get("/bake.json")->status, 404);  // no bake view on this server
}

TEST(ConsoleServer, OffLoopbackEveryPageButTheLoginAsksForTheToken) {
  StatusHandlers handlers = with_status();
  handlers.token = "a-long-enough-secret";
  StatusServer server("127.0.0.1", 0, handlers);
  httplib::Client client("127.0.0.1", server.port());

  EXPECT_EQ(client.Get("/status")->status, 401);
  EXPECT_EQ(client.Get("/frame.jpg")->status, 401);
  const auto login = client.Get("/");
  ASSERT_TRUE(login);
  EXPECT_EQ(login->status, 401);
  EXPECT_NE(login->body.find("<form id=login"), std::string::npos);
  EXPECT_EQ(client.Get("/console.css")->status, 200);  // the login form's own style

  EXPECT_EQ(client.Get("/status", {{"Authorization", "Bearer a-long-enough-secret"}})->status, 200);
  EXPECT_EQ(client.Get("/status", {{"Authorization", "Bearer a-long-enough-secreT"}})->status, 401);
  EXPECT_EQ(client.Get("/status", {{"Cookie", "other=1; skylit_token=a-long-enough-secret"}})->status, 200);

  const auto wrong = client.Post("/login", "token=guess", "application/x-www-form-urlencoded");
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->status, 401);
  const auto right = client.Post("/login", "token=a-long-enough-secret", "application/x-www-form-urlencoded");
  ASSERT_TRUE(right);
  EXPECT_EQ(right->status, 303);
  EXPECT_EQ(right->get_header_value("Location"), "/");
  const std::string cookie = right->get_header_value("Set-Cookie");
  EXPECT_EQ(cookie.rfind("skylit_token=a-long-enough-secret;", 0), 0u) << cookie;
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos);
}

TEST(ConsoleServer, AnAddressOffLoopbackNeedsATokenOrAnExplicitOptOut) {
  EXPECT_EQ(status_token("127.0.0.1", {}, false, "test"), "");
  EXPECT_EQ(status_token("localhost", {}, false, "test"), "");
  EXPECT_EQ(status_token("::1", {}, false, "test"), "");
  try {
    status_token("0.0.0.0", {}, false, "test");
    FAIL() << "an open console off loopback was allowed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("status.token_file"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("allow_unauthenticated"), std::string::npos) << e.what();
  }
  EXPECT_EQ(status_token("0.0.0.0", {}, true, "test"), "");  // on purpose: a warning, no token
  const test::TempDir dir("skylit_token_");
  EXPECT_EQ(status_token("0.0.0.0", dir.write("token", "s3cret-and-long\n"), false, "test"), "s3cret-and-long");
  EXPECT_THROW(status_token("0.0.0.0", dir.write("short", "abc\n"), false, "test"), InputError);
}

TEST(ConsoleServer, AFrameIsEncodedOnceHoweverManyAskForIt) {
  Latest<cv::Mat> latest;
  JpegCache cache;
  EXPECT_TRUE(cache.get(latest).empty());  // no frame yet
  latest.set(cv::Mat(48, 64, CV_8UC3, cv::Scalar(10, 200, 30)));
  const std::vector<std::uint8_t> first = cache.get(latest);
  ASSERT_GT(first.size(), 100u);
  EXPECT_EQ(first[0], 0xFF);
  EXPECT_EQ(first[1], 0xD8);
  for (int page = 0; page < 5; ++page) EXPECT_EQ(cache.get(latest), first);
  EXPECT_EQ(cache.encodes(), 1u);
  latest.set(cv::Mat(48, 64, CV_8UC3, cv::Scalar(200, 10, 30)));
  EXPECT_NE(cache.get(latest), first);  // a new frame: encoded again
  EXPECT_EQ(cache.encodes(), 2u);
  EXPECT_EQ(latest.version(), 2u);
}

}  // namespace
}  // namespace skylit::live
