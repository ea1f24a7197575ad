#include "skylit/base/yaml_reader.hpp"

#include <gtest/gtest.h>

#include <array>
#include <string>
#include <string_view>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"

namespace skylit {
namespace yaml_reader_test {  // named, not anonymous: the test program is one unity build

using test::TempDir;

// The site, calibration and response readers rely on these; each once had its own copy.
TEST(YamlReader, SyntaxErrorsNameTheLineAndTheReadersFix) {
  TempDir dir;
  const YamlReader r(dir.write("bad.yaml", "a: 1\nb: [2\n"));
  const std::string message = test::error_of([&] { (void)r.load("see docs/x.md"); });
  EXPECT_NE(message.find("bad.yaml:3:"), std::string::npos) << message;
  EXPECT_NE(message.find("YAML syntax error"), std::string::npos) << message;
  EXPECT_NE(message.find("Fix: see docs/x.md"), std::string::npos) << message;
  const std::string parsed = test::error_of([&] { (void)r.parse("x: {"); });
  EXPECT_NE(parsed.find("bad.yaml:1:"), std::string::npos) << parsed;
  EXPECT_NE(parsed.find(YamlReader::kSyntaxFix), std::string::npos) << parsed;
  EXPECT_TRUE(YamlReader(dir.write("empty.yaml", "")).load().IsNull());
  EXPECT_NE(test::error_of([&] { (void)YamlReader(dir.path() / "none.yaml").load(); }).find("does not exist"),
            std::string::npos);
}

TEST(YamlReader, AMissingFieldAndAFieldWithoutAValueAreTold) {
  TempDir dir;
  const YamlReader r(dir.write("f.yaml", ""));
  const YAML::Node root = r.parse("top:\n  a: 1\n  b:\n  c: 3\n");
  const YAML::Node top = root["top"];
  EXPECT_EQ(r.require(top, "a", "top.a", "x").as<int>(), 1);
  const std::string missing = test::error_of([&] { (void)r.require(top, "d", "top.d", "'d: 4'"); });
  EXPECT_NE(missing.find("f.yaml:2:3: field 'top.d': required field is missing. Fix: add it: 'd: 4'"), std::string::npos)
      << missing;
  // The null value's own mark is past it; the message points at the key.
  const std::string empty = test::error_of([&] { (void)r.require(top, "b", "top.b", "give b"); });
  EXPECT_NE(empty.find("f.yaml:3:3: field 'top.b': the field has no value. Fix: give b"), std::string::npos) << empty;
  EXPECT_EQ(YamlReader::key_node(top, "c").Scalar(), "c");
  EXPECT_FALSE(YamlReader::optional(top, "b").IsDefined());
}

TEST(YamlReader, IntegersAndListsOfNumbers) {
  TempDir dir;
  const YamlReader r(dir.write("n.yaml", ""));
  const YAML::Node root = r.parse("a: 12\nb: 12.5\nc: 99999999999999999999\nd: 0x1F\ne: [1, 2.5, -3]\nf: [1, x]\ng: 4\n");
  EXPECT_EQ(r.integer(root["a"], "a", 0, 100, "fix"), 12);
  EXPECT_EQ(r.integer(root["d"], "d", 0, 100, "fix"), 31);  // USB ids are written in hex
  EXPECT_NE(test::error_of([&] { (void)r.integer(root["b"], "b", 0, 100, "fix"); }).find("field 'b': expected an integer, got '12.5'"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { (void)r.integer(root["c"], "c", 1, 100, "fix"); }).find("99999999999999999999 is outside 1..100"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { (void)r.integer(root["a"], "a", 1, 10, "fix"); }).find("12 is outside 1..10"), std::string::npos);
  EXPECT_EQ(r.numbers(root["e"], "e", "fix"), (std::vector<double>{1, 2.5, -3}));
  EXPECT_EQ(r.numbers(root["e"], 3, "e", "fix").size(), 3u);
  EXPECT_NE(test::error_of([&] { (void)r.numbers(root["e"], 2, "e", "fix"); }).find("expected a list of 2 numbers"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { (void)r.numbers(root["f"], "f", "fix"); }).find("n.yaml:6:8: field 'f': element 1 is not a finite number"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { (void)r.numbers(root["g"], "g", "fix"); }).find("field 'g': expected a list of numbers"),
            std::string::npos);
}

TEST(YamlReader, UnknownAndRepeatedKeys) {
  TempDir dir;
  const YamlReader r(dir.write("k.yaml", ""));
  constexpr std::array<std::string_view, 2> kAllowed{"frequency", "basis"};
  const std::string typo = test::error_of([&] { r.check_keys(r.parse("frequncy: 2\n"), "dome.", kAllowed); });
  EXPECT_NE(typo.find("field 'dome.frequncy': unknown field. Fix: did you mean 'frequency'?"), std::string::npos) << typo;
  const std::string twice = test::error_of([&] { r.check_keys(r.parse("basis: a\nbasis: b\n"), "", kAllowed); });
  EXPECT_NE(twice.find("k.yaml:2:1: field 'basis': the field appears twice"), std::string::npos) << twice;
}

}  // namespace
}  // namespace skylit
