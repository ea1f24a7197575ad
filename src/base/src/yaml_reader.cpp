#include "skylit/base/yaml_reader.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>
#include <system_error>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit {
namespace {

[[noreturn]] void syntax_error(const std::filesystem::path& file, const YAML::ParserException& e,
                               const std::string& fix) {
  throw InputError(input_message(file, e.mark.line + 1, e.mark.column + 1, "", "YAML syntax error: " + e.msg, fix));
}

}  // namespace

YAML::Node YamlReader::load(const std::string& syntax_fix) const {
  if (!std::filesystem::exists(file_)) {
    throw InputError(input_message(file_, -1, -1, "", "the file does not exist", "check the path"));
  }
  // Read through read_file: its errors name the cause, and it stops at a size no config has.
  return parse(read_file(file_), syntax_fix);
}

YAML::Node YamlReader::parse(const std::string& text, const std::string& syntax_fix) const {
  try {
    return YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    syntax_error(file_, e, syntax_fix);
  }
}

void YamlReader::fail(const YAML::Node& node, const std::string& field, const std::string& problem,
                      const std::string& fix) const {
  int line = -1, column = -1;
  if (node.IsDefined() && node.Mark().line >= 0) {
    line = node.Mark().line + 1;
    column = node.Mark().column + 1;
  }
  throw InputError(input_message(file_, line, column, field, problem, fix));
}

void YamlReader::check_keys(const YAML::Node& map, const std::string& prefix,
                            std::span<const std::string_view> allowed) const {
  std::set<std::string> seen;
  for (const auto& entry : map) {
    const YAML::Node& key = entry.first;
    if (!key.IsScalar()) fail(key, prefix, "a key is not a plain name", "use plain names as keys");
    const std::string name = key.Scalar();
    if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
      fail(key, prefix + name, "unknown field", unknown_key_fix(name, allowed));
    }
    if (!seen.insert(name).second) fail(key, prefix + name, "the field appears twice", "keep one of them");
  }
}

void YamlReader::expect_map(const YAML::Node& node, const std::string& field, const std::string& fix) const {
  if (!node.IsMap()) fail(node, field, "expected a map of fields", fix);
}

YAML::Node YamlReader::optional(const YAML::Node& map, const std::string& key) {
  const YAML::Node node = map[key];
  if (!node.IsDefined() || node.IsNull()) return YAML::Node(YAML::NodeType::Undefined);
  return node;
}

YAML::Node YamlReader::require(const YAML::Node& map, const std::string& key, const std::string& field,
                               const std::string& fix) const {
  const YAML::Node node = map[key];
  if (!node.IsDefined()) fail(map, field, "required field is missing", "add it: " + fix);
  if (node.IsNull()) fail(key_node(map, key), field, "the field has no value", fix);
  return node;
}

YAML::Node YamlReader::key_node(const YAML::Node& map, const std::string& key) {
  for (const auto& entry : map) {
    if (entry.first.IsScalar() && entry.first.Scalar() == key) return entry.first;
  }
  return map;
}

std::string YamlReader::text(const YAML::Node& node, const std::string& field, const std::string& fix) const {
  if (!node.IsScalar() || node.Scalar().empty()) fail(node, field, "expected a text value", fix);
  return node.Scalar();
}

double YamlReader::number(const YAML::Node& node, const std::string& field, const std::string& fix) const {
  if (!node.IsScalar()) fail(node, field, "expected a number", fix);
  double value = 0;
  try {
    value = node.as<double>();
  } catch (const YAML::BadConversion&) {
    fail(node, field, "'" + node.Scalar() + "' is not a number", fix);
  }
  if (!std::isfinite(value)) fail(node, field, "the number is not finite", fix);
  return value;
}

double YamlReader::non_negative(const YAML::Node& node, const std::string& field, const std::string& fix) const {
  const double value = number(node, field, fix);
  if (value < 0) fail(node, field, "must not be negative, got " + node.Scalar(), fix);
  return value;
}

double YamlReader::positive(const YAML::Node& node, const std::string& field, const std::string& fix) const {
  const double value = number(node, field, fix);
  if (value <= 0) fail(node, field, "must be positive, got " + node.Scalar(), fix);
  return value;
}

long long YamlReader::integer(const YAML::Node& node, const std::string& field, long long lo, long long hi,
                              const std::string& fix) const {
  if (!node.IsScalar()) fail(node, field, "expected an integer", fix);
  const std::string& text = node.Scalar();
  const std::string range = text + " is outside " + std::to_string(lo) + ".." + std::to_string(hi);
  long long value = 0;
  try {
    value = node.as<long long>();  // decimal, or hexadecimal with 0x (USB ids)
  } catch (const YAML::BadConversion&) {
    // Decimal digits that do not fit 64 bits are out of range, not "not an integer".
    const char* first = text.data() + (text.starts_with('+') ? 1 : 0);
    long long ignored = 0;
    if (std::from_chars(first, text.data() + text.size(), ignored).ec == std::errc::result_out_of_range) {
      fail(node, field, range, fix);
    }
    fail(node, field, "expected an integer, got '" + text + "'", fix);
  }
  if (value < lo || value > hi) fail(node, field, range, fix);
  return value;
}

bool YamlReader::boolean(const YAML::Node& node, const std::string& field, const std::string& fix) const {
  if (!node.IsScalar()) fail(node, field, "expected true or false", fix);
  try {
    return node.as<bool>();
  } catch (const YAML::BadConversion&) {
    fail(node, field, "'" + node.Scalar() + "' is not true or false", fix);
  }
}

std::vector<double> YamlReader::numbers(const YAML::Node& node, std::size_t count, const std::string& field,
                                        const std::string& fix) const {
  if (!node.IsSequence() || node.size() != count) {
    fail(node, field, "expected a list of " + std::to_string(count) + " numbers", fix);
  }
  return numbers(node, field, fix);
}

std::vector<double> YamlReader::numbers(const YAML::Node& node, const std::string& field, const std::string& fix) const {
  if (!node.IsSequence()) fail(node, field, "expected a list of numbers", fix);
  std::vector<double> values;
  for (std::size_t i = 0; i < node.size(); ++i) {
    const YAML::Node element = node[i];
    double value = 0;
    bool ok = element.IsScalar();
    if (ok) {
      try {
        value = element.as<double>();
      } catch (const YAML::BadConversion&) {
        ok = false;
      }
    }
    if (!ok || !std::isfinite(value)) fail(element, field, "element " + std::to_string(i) + " is not a finite number", fix);
    values.push_back(value);
  }
  return values;
}

std::string YamlReader::choice(const YAML::Node& node, const std::string& field,
                               std::span<const std::string_view> choices) const {
  std::string allowed;
  for (auto c : choices) allowed += (allowed.empty() ? "" : " | ") + std::string(c);
  const std::string value = text(node, field, "one of " + allowed);
  if (std::find(choices.begin(), choices.end(), value) == choices.end()) {
    fail(node, field, "'" + value + "' is not allowed", unknown_key_fix(value, choices));
  }
  return value;
}

std::filesystem::path YamlReader::root() const {
  std::filesystem::path folder = (root_.empty() ? file_.parent_path() : root_).lexically_normal();
  // "a/b/.." normalises to "a/": named without the trailing separator.
  if (!folder.has_filename() && folder.has_relative_path()) folder = folder.parent_path();
  return folder.empty() ? std::filesystem::path(".") : folder;  // a file named without a folder
}

void YamlReader::read_root(const YAML::Node& document) {
  if (!document.IsMap()) return;
  const YAML::Node node = optional(document, "root");
  if (!node) return;
  const std::filesystem::path value(text(node, "root", "a folder holding every file this one names, e.g. 'root: ..'"));
  root_ = value.is_absolute() ? value : file_.parent_path() / value;
}

std::filesystem::path YamlReader::path(const YAML::Node& node, const std::string& field, const std::string& fix) const {
  const std::filesystem::path resolved = any_path(node, field, fix);
  if (!contains(root(), resolved)) {
    fail(node, field,
         "'" + node.Scalar() + "' is outside the folder this file may name files in, '" + root().string() + "'",
         "move the file under that folder, or make the folder wider with 'root: FOLDER' at the top of this file "
         "(relative to it, e.g. 'root: ..')");
  }
  return resolved;
}

std::filesystem::path YamlReader::any_path(const YAML::Node& node, const std::string& field, const std::string& fix) const {
  const std::filesystem::path value(text(node, field, fix));
  return value.is_absolute() ? value.lexically_normal() : (file_.parent_path() / value).lexically_normal();
}

bool contains(const std::filesystem::path& folder, const std::filesystem::path& path) {
  // Compared as absolute, normal paths (".." resolved by the names, not by following links: a
  // link an installer put inside the folder is theirs to point anywhere).
  const std::filesystem::path outer = std::filesystem::absolute(folder).lexically_normal();
  const std::filesystem::path inner = std::filesystem::absolute(path).lexically_normal();
  auto o = outer.begin();
  auto i = inner.begin();
  for (; o != outer.end() && !o->empty(); ++o, ++i) {  // a trailing "/" gives an empty last name
    if (i == inner.end() || *o != *i) return false;
  }
  return true;
}

}  // namespace skylit
