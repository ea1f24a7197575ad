// What every program does alike (docs/architecture.md, "Conventions every program keeps"): an
// input file that is not there exits 2 with a message naming it, an option the program does not
// know exits 2 too, --help exits 0, --version and the usage line name the program, -q keeps the
// errors. Nothing here does any work: each case costs a program start.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cli_support.hpp"

namespace skylit_cli_test {  // named, not anonymous: the test program is one unity build

namespace fs = std::filesystem;

using skylit::cli_test::kBin;
using skylit::cli_test::kSource;
using skylit::cli_test::Result;
using skylit::cli_test::TempDir;

struct Program {
  std::string name;
  // Arguments with @MISSING@ where a file that is not there goes (every other input exists);
  // @DIR@ is a folder for outputs, @SRC@ the source tree.
  std::string args;
};
// CTest lists a case by its program, not as a dump of the struct's bytes.
void PrintTo(const Program& program, std::ostream* os) { *os << program.name; }

std::string substitute(std::string text, const std::string& name, const std::string& value) {
  for (auto at = text.find(name); at != std::string::npos; at = text.find(name, at + value.size())) {
    text.replace(at, name.size(), value);
  }
  return text;
}

class SkylitCli : public ::testing::TestWithParam<Program> {
 protected:
  Result run(const std::string& args) const {
    std::string expanded = substitute(args, "@DIR@", dir_.path().string());
    expanded = substitute(expanded, "@SRC@", kSource.string());
    expanded = substitute(expanded, "@MISSING@", missing().string());
    return skylit::cli_test::run_program(kBin / GetParam().name, expanded);
  }
  fs::path missing() const { return dir_ / "not_here.yaml"; }
  TempDir dir_;
};

TEST_P(SkylitCli, AMissingInputFileIsAnInputErrorNamingIt) {
  ASSERT_TRUE(fs::exists(kBin / GetParam().name)) << "build " << GetParam().name << " first";
  fs::create_directories(dir_ / "bake");
  const Result r = run(GetParam().args);
  EXPECT_EQ(r.status, 2) << GetParam().args << "\n" << r.output;
  EXPECT_NE(r.output.find(missing().string()), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
}

// Inputs as people bring them, each in a path with a space and non-ASCII letters: an empty file,
// a folder, and bytes of the wrong kind. Each is an input error naming the path; none crashes.
TEST_P(SkylitCli, AnEmptyFileAFolderAndTheWrongKindOfFileAreInputErrorsNamingThem) {
  ASSERT_TRUE(fs::exists(kBin / GetParam().name)) << "build " << GetParam().name << " first";
  fs::create_directories(dir_ / "bake");
  const fs::path empty = dir_.write("vide é ☀.yaml", "");
  const fs::path folder = dir_ / "dossier é ☀.yaml";
  fs::create_directories(folder);
  std::string bytes;
  for (int k = 0; k < 4096; ++k) bytes.push_back(static_cast<char>((k * 131 + 7) % 251));
  const fs::path garbage = dir_.write("déchets ☀.yaml", bytes);
  for (const fs::path& input : {empty, folder, garbage}) {
    std::string args = substitute(GetParam().args, "@MISSING@", "'" + input.string() + "'");
    const Result r = run(args);
    EXPECT_EQ(r.status, 2) << input << "\n" << r.output;
    EXPECT_NE(r.output.find(input.filename().string()), std::string::npos) << input << "\n" << r.output;
    EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
  }
}

// A file the program may not read: an input error naming it and the cause. The tests run as root,
// who reads anything, so the program then runs as nobody (setpriv), as a service account would.
TEST_P(SkylitCli, AFileItCannotReadIsAnInputErrorNamingIt) {
  ASSERT_TRUE(fs::exists(kBin / GetParam().name)) << "build " << GetParam().name << " first";
  fs::create_directories(dir_ / "bake");
  fs::permissions(dir_.path(), fs::perms::all);  // the program may write its outputs here
  fs::permissions(dir_ / "bake", fs::perms::all);
  const fs::path locked = dir_.write("verrouillé ☀.yaml", "scene:\n  model: gate.glb\n");
  fs::permissions(locked, fs::perms::none);
  const std::string as_nobody = ::geteuid() == 0 ? "setpriv --reuid=nobody --regid=nogroup --clear-groups " : "";
  std::string args = substitute(GetParam().args, "@MISSING@", "'" + locked.string() + "'");
  args = substitute(substitute(args, "@DIR@", dir_.path().string()), "@SRC@", kSource.string());
  const Result r = skylit::cli_test::run_program(as_nobody + (kBin / GetParam().name).string(), args);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find(locked.filename().string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("ermission denied"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
}

TEST_P(SkylitCli, AnUnknownOptionIsAnInputErrorAndHelpIsNot) {
  ASSERT_TRUE(fs::exists(kBin / GetParam().name)) << "build " << GetParam().name << " first";
  // (A program with required options may name those first.)
  const Result unknown = run("--no-such-option");
  EXPECT_EQ(unknown.status, 2) << unknown.output;
  EXPECT_NE(unknown.output.find(GetParam().name + ": error: "), std::string::npos) << unknown.output;
  const Result help = run("--help");
  EXPECT_EQ(help.status, 0) << help.output;
  EXPECT_NE(help.output.find("--help"), std::string::npos) << help.output;
}

TEST_P(SkylitCli, VersionAndUsageNameTheProgramAndQuietKeepsTheErrors) {
  ASSERT_TRUE(fs::exists(kBin / GetParam().name)) << "build " << GetParam().name << " first";
  const Result version = run("--version");
  EXPECT_EQ(version.status, 0) << version.output;
  EXPECT_EQ(version.output.rfind(GetParam().name + " ", 0), 0u) << version.output;
  const Result help = run("--help");
  EXPECT_NE(help.output.find("Usage: " + GetParam().name), std::string::npos) << help.output;
  // -q is taken (after a subcommand too) and leaves the input error, with its exit status.
  fs::create_directories(dir_ / "bake");
  const Result quiet = run(GetParam().args + " -q");
  EXPECT_EQ(quiet.status, 2) << quiet.output;
  EXPECT_NE(quiet.output.find(missing().string()), std::string::npos) << quiet.output;
}

INSTANTIATE_TEST_SUITE_P(
    Programs, SkylitCli,
    ::testing::Values(
        Program{"skylit-bake", "@MISSING@ -o @DIR@/out"},
        Program{"skylit-shade",
                "--bake @DIR@/bake --sky @MISSING@ --sky-calib @SRC@/config/sky_camera.yaml -o @DIR@/out"},
        Program{"skylit-sky", "--calib @SRC@/config/sky_camera.yaml --equirect @MISSING@ -o @DIR@/out.exr"},
        Program{"skylit-compose",
                "--site @MISSING@ --bake @DIR@/bake --sky-calib @SRC@/config/sky_camera.yaml --sky "
                "@SRC@/data/hdri/park.exr --hmd-calib @SRC@/config/hmd_camera.yaml --camera @SRC@/data/hdri/park.exr "
                "-o @DIR@/out.png"},
        Program{"skylit-calib", "sky-orientation --calib @MISSING@ --level-compass 0"},
        Program{"skylit-camera-sim", "--calib @MISSING@ -o @DIR@/out"},
        Program{"skylit-contact-sheet", "@MISSING@ -o @DIR@/sheet.png"},
        Program{"skylit-live", "@MISSING@"},
        Program{"skylit-sky-node", "@MISSING@"},
        Program{"skylit-bench", "trade --site @MISSING@ --calib @SRC@/config/sky_camera.yaml --hmd-camera @SRC@/config/hmd_camera.yaml --skies @SRC@/data/hdri --out @DIR@/trade"}),
    [](const ::testing::TestParamInfo<Program>& param_info) {
      std::string name = param_info.param.name.substr(std::string("skylit-").size());
      for (char& c : name) {
        if (c == '-') c = '_';
      }
      return name;
    });

}  // namespace skylit_cli_test
