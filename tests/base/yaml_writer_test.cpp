#include "skylit/base/yaml_writer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace skylit {
namespace {

TEST(FormatNumber, IsTheShortestTextThatReadsBackExactly) {
  EXPECT_EQ(format_number(0.1), "0.1");
  EXPECT_EQ(format_number(0.1 + 0.2), "0.30000000000000004");
  EXPECT_EQ(format_number(1e300), "1e+300");
  EXPECT_EQ(format_number(-2.5e-7), "-2.5e-07");
  EXPECT_EQ(format_number(512.0), "512");
  EXPECT_EQ(format_number(0.1F), "0.1");
  for (const double v : {1.0 / 3.0, std::nextafter(1.0, 2.0), 5e-324, -1.7976931348623157e308}) {
    EXPECT_EQ(std::strtod(format_number(v).c_str(), nullptr), v);  // stod refuses subnormals
  }
}

// What the hand-written writers got wrong: a newline inside quotes is folded into a space.
TEST(YamlWriter, TextRoundTripsWhateverItHolds) {
  const std::vector<std::string> texts = {
      "plain",        "null",   "true",     "~",     "",       "a: b",          "a #b",     "\"quoted\"",
      "back\\slash",  "line\nbreak", "two\n\nbreaks\n", " padded ", "tab\there", "- dash", "[flow]", "{map}",
      "ünïcode × ·", "'single'", "%percent", "@at",   "12",     "1e3",
  };
  YAML::Emitter out;
  out << YAML::BeginSeq;
  for (const std::string& text : texts) out << YamlText{text};
  out << YAML::EndSeq;
  const YAML::Node back = YAML::Load(yaml_document(out));
  ASSERT_EQ(back.size(), texts.size());
  for (std::size_t i = 0; i < texts.size(); ++i) {
    EXPECT_TRUE(back[i].IsScalar()) << texts[i];
    EXPECT_EQ(back[i].Scalar(), texts[i]);
  }
}

TEST(YamlWriter, NumbersCommentsAndTheDocument) {
  const std::vector<double> values{1.0 / 3.0, -0.0, 1e-300, 42};
  YAML::Emitter out;
  out << YamlCommentLine{"first line\nsecond line"} << YAML::BeginMap;
  out << YAML::Key << "x" << YAML::Value << YamlNumber{0.1} << YAML::Comment("a note");
  out << YamlCommentLine{"before y"};
  out << YAML::Key << "y" << YAML::Value << YamlNumbers{values};
  out << YAML::Key << "odd" << YAML::Value << YamlNumbers{std::vector<double>{
                                                 std::numeric_limits<double>::infinity(),
                                                 -std::numeric_limits<double>::infinity(),
                                                 std::numeric_limits<double>::quiet_NaN()}};
  out << YAML::EndMap;
  const std::string text = yaml_document(out);
  EXPECT_EQ(text,
            "# first line\n# second line\n"
            "x: 0.1  # a note\n"
            "# before y\n"
            "y: [0.3333333333333333, -0, 1e-300, 42]\n"
            "odd: [.inf, -.inf, .nan]\n");
  const YAML::Node back = YAML::Load(text);
  EXPECT_EQ(back["x"].as<double>(), 0.1);
  for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(back["y"][i].as<double>(), values[i]);
  EXPECT_TRUE(std::isinf(back["odd"][0].as<double>()));
  EXPECT_TRUE(std::isnan(back["odd"][2].as<double>()));
}

TEST(YamlWriter, AWritersMistakeIsALogicError) {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "k" << YAML::Value << YAML::EndMap << YAML::EndMap;
  EXPECT_THROW((void)yaml_document(out), std::logic_error);
}

}  // namespace
}  // namespace skylit
