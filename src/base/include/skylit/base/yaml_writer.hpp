#pragma once
// Writing YAML through yaml-cpp's emitter, which does the quoting and escaping: numbers as the
// shortest text that reads back to the same value, text double-quoted, comments on their own lines.
#include <span>
#include <string>
#include <string_view>

#include <yaml-cpp/yaml.h>

namespace skylit {

// The shortest text that reads back as exactly the same value (std::to_chars): 0.1, 1e+300.
std::string format_number(double value);
std::string format_number(float value);

// Values for YAML::Emitter's operator<<:
//   out << YamlNumber{x}          format_number's text (the emitter's own gives 0.1 as
//                                 0.10000000000000001); .inf, -.inf and .nan spelled as YAML does
//   out << YamlNumbers{values}    a flow list of them: [1, 0.5, 2]
//   out << YamlText{text}         double-quoted and escaped, whatever it holds (newlines, ': ',
//                                 '#', quotes, words such as null)
//   out << YamlCommentLine{text}  "# text" on a line of its own, one line per line of text
struct YamlNumber {
  double value;
};
struct YamlNumbers {
  std::span<const double> values;
};
struct YamlText {
  std::string_view text;
};
struct YamlCommentLine {
  std::string_view text;
};

YAML::Emitter& operator<<(YAML::Emitter& out, const YamlNumber& number);
YAML::Emitter& operator<<(YAML::Emitter& out, const YamlNumbers& numbers);
YAML::Emitter& operator<<(YAML::Emitter& out, const YamlText& text);
YAML::Emitter& operator<<(YAML::Emitter& out, const YamlCommentLine& comment);

// The emitter's document as a file's text, ending in a newline. std::logic_error when the
// emitter reports a mistake of the writer's (a key without a value, an unclosed map).
std::string yaml_document(const YAML::Emitter& out);

}  // namespace skylit
