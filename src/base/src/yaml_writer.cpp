#include "skylit/base/yaml_writer.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <stdexcept>

namespace skylit {
namespace {

template <typename T>
std::string shortest(T value) {
  std::array<char, 64> buffer{};  // holds any double
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  return std::string(buffer.data(), result.ptr);
}

}  // namespace

std::string format_number(double value) { return shortest(value); }
std::string format_number(float value) { return shortest(value); }

YAML::Emitter& operator<<(YAML::Emitter& out, const YamlNumber& number) {
  const double v = number.value;
  // to_chars writes inf and nan, which YAML reads as words.
  if (std::isnan(v)) return out << ".nan";
  if (std::isinf(v)) return out << (v > 0 ? ".inf" : "-.inf");
  return out << format_number(v);
}

YAML::Emitter& operator<<(YAML::Emitter& out, const YamlNumbers& numbers) {
  out << YAML::Flow << YAML::BeginSeq;
  for (const double v : numbers.values) out << YamlNumber{v};
  return out << YAML::EndSeq;
}

YAML::Emitter& operator<<(YAML::Emitter& out, const YamlText& text) {
  return out << YAML::DoubleQuoted << std::string(text.text);
}

YAML::Emitter& operator<<(YAML::Emitter& out, const YamlCommentLine& comment) {
  // Without the newline the emitter puts the comment after the value before it.
  if (out.size() > 0) out << YAML::Newline;
  return out << YAML::Comment(std::string(comment.text));
}

std::string yaml_document(const YAML::Emitter& out) {
  if (!out.good()) throw std::logic_error("writing YAML: " + out.GetLastError());
  return std::string(out.c_str(), out.size()) + "\n";
}

}  // namespace skylit
