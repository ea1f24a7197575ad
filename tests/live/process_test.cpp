// skylit-live as a process, as systemd runs it: SIGTERM ends it with exit status 0 and a closed,
// readable recording.
#include <cctype>
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "../cli/cli_support.hpp"
#include "../support/virtual_display.hpp"
#include "live_fixture.hpp"

namespace skylit::live_test {
namespace {

using namespace std::chrono_literals;

// A child process running `program args...`, its stdout and stderr into `log`.
pid_t spawn(const fs::path& program, const std::vector<std::string>& args, const fs::path& log) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
    }
    std::vector<char*> argv{const_cast<char*>(program.c_str())};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(program.c_str(), argv.data());
    ::_exit(127);
  }
  return pid;
}

// Waits up to `timeout` for the child; its wait status, or nullopt while it still runs.
std::optional<int> wait_child(pid_t pid, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) return status;
    std::this_thread::sleep_for(20ms);
  }
  return std::nullopt;
}

std::string read_text(const fs::path& file) {
  std::ostringstream out;
  out << std::ifstream(file).rdbuf();
  return out.str();
}

// The largest frame count the progress lines of `text` report ("skylit-live: N frames, ...").
long logged_frames(const std::string& text) {
  long most = 0;
  for (std::size_t at = text.find(" frames, "); at != std::string::npos; at = text.find(" frames, ", at + 1)) {
    std::size_t begin = at;
    while (begin > 0 && std::isdigit(static_cast<unsigned char>(text[begin - 1]))) --begin;
    if (begin < at) most = std::max(most, std::stol(text.substr(begin, at - begin)));
  }
  return most;
}

TEST(SkylitLive, SigtermEndsItCleanlyWithAReadableRecording) {
  const Rig rig;  // the camera loops at 30 frames per second: it runs until told to stop
  const fs::path program = cli_test::kBin / "skylit-live";
  ASSERT_TRUE(fs::exists(program)) << program;
  const fs::path video = rig.dir() / "live.mp4", log = rig.dir() / "log.txt";
  const pid_t pid = spawn(program, {rig.config_file().string(), "--headless", "--record", video.string()}, log);
  ASSERT_GT(pid, 0);

  // Running: the progress line shows frames (it is written once a second).
  const auto end = std::chrono::steady_clock::now() + 60s;
  while (read_text(log).find(" frames, ") == std::string::npos && std::chrono::steady_clock::now() < end) {
    if (wait_child(pid, 0s)) break;
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_NE(read_text(log).find(" frames, "), std::string::npos) << read_text(log);
  // Ten more frames recorded (the progress line counts them; it is written once a second).
  const long first = logged_frames(read_text(log));
  while (logged_frames(read_text(log)) < first + 10 && std::chrono::steady_clock::now() < end) {
    if (wait_child(pid, 0s)) break;
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_GE(logged_frames(read_text(log)), first + 10) << read_text(log);
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  std::optional<int> status = wait_child(pid, 30s);
  if (!status) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
    FAIL() << "skylit-live did not end within 30 s of SIGTERM\n" << read_text(log);
  }
  const std::string output = read_text(log);
  ASSERT_TRUE(WIFEXITED(*status)) << output;
  EXPECT_EQ(WEXITSTATUS(*status), 0) << output;
  EXPECT_NE(output.find("SIGTERM, stopping"), std::string::npos) << output;
  EXPECT_NE(output.find("frames composited"), std::string::npos) << output;

  // The recording was closed: a player reads it through to the end.
  cv::VideoCapture capture(video.string());
  ASSERT_TRUE(capture.isOpened()) << video;
  int frames = 0;
  cv::Mat frame;
  while (capture.read(frame)) {
    EXPECT_EQ(frame.size(), cv::Size(96, 72));
    ++frames;
  }
  std::printf("measured: %d frames read back from the recording after SIGTERM\n", frames);
  EXPECT_GT(frames, 0);
}

TEST(SkylitLive, AWindowedRunUnderXvfbShowsTheFrames) {
  const gpu::test::VirtualDisplay xvfb("320x240x24");
  if (xvfb.display().empty()) GTEST_SKIP() << "Xvfb is not installed (apt install xvfb)";
  const gpu::test::ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const gpu::test::ScopedEnv wayland("WAYLAND_DISPLAY", nullptr);
  RigOptions options;
  options.extra = "output:\n  window: true\n";
  const Rig rig(options);
  const cli_test::Result result = cli_test::run_program(cli_test::kBin / "skylit-live", rig.config_file().string() + " --frames 10");
  EXPECT_EQ(result.status, 0) << result.output;
  EXPECT_NE(result.output.find("in a window"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("10 frames composited"), std::string::npos) << result.output;
}

TEST(SkylitLive, ABadConfigExitsWithStatus2AndTheMessage) {
  const Rig rig;
  std::ofstream(rig.dir() / "bad.yaml") << rig.config_text() << "blend:\n  storage: float16\n";
  const cli_test::Result result = cli_test::run_program(cli_test::kBin / "skylit-live", (rig.dir() / "bad.yaml").string());
  EXPECT_EQ(result.status, 2) << result.output;
  EXPECT_NE(result.output.find("blend.storage"), std::string::npos) << result.output;
}

}  // namespace
}  // namespace skylit::live_test
