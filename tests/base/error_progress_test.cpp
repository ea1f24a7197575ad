#include <gtest/gtest.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "skylit/base/error.hpp"
#include "skylit/base/progress.hpp"

namespace skylit {
namespace {

TEST(InputMessage, NamesFileLineFieldAndFix) {
  EXPECT_EQ(input_message("site.yaml", 12, 3, "planes[0].width", "must be positive, got -4", "set it to texels"),
            "site.yaml:12:3: field 'planes[0].width': must be positive, got -4. Fix: set it to texels");
  EXPECT_EQ(input_message("site.yaml", 12, -1, "dome.frequency", "must be even.", "use 2, 4, 6 or 8"),
            "site.yaml:12: field 'dome.frequency': must be even. Fix: use 2, 4, 6 or 8");
  EXPECT_EQ(input_message("bake/manifest.json", -1, -1, "", "missing", "re-run the baker"),
            "bake/manifest.json: missing. Fix: re-run the baker");
}

TEST(FormatDuration, Cases) {
  EXPECT_EQ(format_duration(0.0), "0.0 s");
  EXPECT_EQ(format_duration(4.2), "4.2 s");
  EXPECT_EQ(format_duration(59.9), "59.9 s");
  EXPECT_EQ(format_duration(59.97), "1 min 00 s");
  EXPECT_EQ(format_duration(185.0), "3 min 05 s");
  EXPECT_EQ(format_duration(3599.4), "59 min 59 s");
  EXPECT_EQ(format_duration(3720.0), "1 h 02 min");
  EXPECT_EQ(format_duration(36000.0 + 59 * 60 + 50), "11 h 00 min");
  EXPECT_EQ(format_duration(-3.0), "0.0 s");
}

// Reads everything written to a C stream backed by a temporary file (not a terminal).
struct Capture {
  std::FILE* file = std::tmpfile();
  ~Capture() { std::fclose(file); }
  std::string text() const {
    std::fflush(file);
    std::rewind(file);
    std::string s;
    for (int c; (c = std::fgetc(file)) != EOF;) s += static_cast<char>(c);
    return s;
  }
};

TEST(Progress, PlainLinesEveryTenPercentThenDone) {
  Capture capture;
  ASSERT_NE(capture.file, nullptr);
  {
    Progress progress("bake", 40, capture.file);
    for (int i = 0; i < 40; ++i) progress.advance();
    progress.finish();
  }
  const std::string text = capture.text();
  EXPECT_EQ(text.find('\r'), std::string::npos);
  for (int percent = 10; percent <= 100; percent += 10) {
    const std::string line = "bake: " + std::to_string(percent) + "% (" + std::to_string(percent * 40 / 100) + "/40)";
    EXPECT_NE(text.find(line), std::string::npos) << line << "\n" << text;
  }
  EXPECT_NE(text.find("bake: 40% (16/40), ETA "), std::string::npos) << text;
  EXPECT_NE(text.find("bake: done in "), std::string::npos) << text;
  // Eleven lines: ten steps and the final one.
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 11) << text;
}

TEST(Progress, TerminalBarRedrawsInPlace) {
  const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
  ASSERT_GE(master, 0);
  ASSERT_EQ(::grantpt(master), 0);
  ASSERT_EQ(::unlockpt(master), 0);
  std::FILE* terminal = std::fopen(::ptsname(master), "w");
  ASSERT_NE(terminal, nullptr);
  ASSERT_EQ(::isatty(::fileno(terminal)), 1);
  {
    Progress progress("assemble", 40, terminal);
    for (int i = 0; i < 17; ++i) progress.advance();
    progress.finish();
  }
  std::fclose(terminal);
  ::fcntl(master, F_SETFL, O_NONBLOCK);
  std::string text;
  char buffer[4096];
  for (ssize_t n; (n = ::read(master, buffer, sizeof buffer)) > 0;) text.append(buffer, static_cast<std::size_t>(n));
  ::close(master);
  EXPECT_NE(text.find("\rassemble [....................]   0% 0/40"), std::string::npos) << text;
  EXPECT_NE(text.find("\rassemble [####################] 100% 40/40"), std::string::npos) << text;
  EXPECT_NE(text.find("assemble: done in "), std::string::npos) << text;
  // Rate-limited: 17 quick advances draw at most a few frames, not 17.
  EXPECT_LE(std::count(text.begin(), text.end(), '\r') - std::count(text.begin(), text.end(), '\n'), 4) << text;
}

}  // namespace
}  // namespace skylit
