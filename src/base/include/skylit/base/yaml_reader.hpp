#pragma once
// Reading YAML config files with errors a user can act on: every failure is an InputError that
// names the file, line, column and field, and says how to fix it (input_message's format).
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace skylit {

class YamlReader {
 public:
  // `root`: the folder every path the file names must lie in (path()); empty, the file's folder.
  explicit YamlReader(std::filesystem::path file, std::filesystem::path root = {})
      : file_(std::move(file)), root_(std::move(root)) {}

  // How to mend a YAML syntax error, unless a reader says more (its schema's documentation).
  static constexpr const char* kSyntaxFix = "correct the YAML syntax at that line (indentation, colons, brackets)";

  // Parses the file (InputError naming it when missing, unreadable or not YAML, with the line).
  // An empty file gives a null node.
  YAML::Node load(const std::string& syntax_fix = kSyntaxFix) const;
  // Parses text already read from the file (a reader that looks at the text first).
  YAML::Node parse(const std::string& text, const std::string& syntax_fix = kSyntaxFix) const;

  [[noreturn]] void fail(const YAML::Node& node, const std::string& field, const std::string& problem,
                         const std::string& fix) const;
  // Every key of `map` must be in `allowed` (unknown keys get a "did you mean" fix) and appear once.
  void check_keys(const YAML::Node& map, const std::string& prefix, std::span<const std::string_view> allowed) const;
  // A map (InputError otherwise).
  void expect_map(const YAML::Node& node, const std::string& field, const std::string& fix) const;

  // The value of `key`, or an undefined node when absent or null.
  static YAML::Node optional(const YAML::Node& map, const std::string& key);
  // The value of `key`: a missing key is reported at its map ("add it: FIX"), a key without a
  // value at the key itself.
  YAML::Node require(const YAML::Node& map, const std::string& key, const std::string& field,
                     const std::string& fix) const;
  // The node of the key `key` in `map` (for errors about a null value, whose own mark points past
  // it), or `map` itself when absent.
  static YAML::Node key_node(const YAML::Node& map, const std::string& key);

  std::string text(const YAML::Node& node, const std::string& field, const std::string& fix) const;
  double number(const YAML::Node& node, const std::string& field, const std::string& fix) const;
  double non_negative(const YAML::Node& node, const std::string& field, const std::string& fix) const;
  double positive(const YAML::Node& node, const std::string& field, const std::string& fix) const;
  long long integer(const YAML::Node& node, const std::string& field, long long lo, long long hi,
                    const std::string& fix) const;
  bool boolean(const YAML::Node& node, const std::string& field, const std::string& fix) const;
  // Exactly `count` numbers in a sequence.
  std::vector<double> numbers(const YAML::Node& node, std::size_t count, const std::string& field,
                              const std::string& fix) const;
  // A sequence of finite numbers, of any length.
  std::vector<double> numbers(const YAML::Node& node, const std::string& field, const std::string& fix) const;
  // One of `choices`.
  std::string choice(const YAML::Node& node, const std::string& field, std::span<const std::string_view> choices) const;
  // A file or folder the config names as input (a model, a calibration, a bake): relative to the
  // config file's folder unless absolute, and inside root(); InputError naming the field otherwise.
  std::filesystem::path path(const YAML::Node& node, const std::string& field, const std::string& fix) const;
  // The same without the root: a secret (token, password, TLS key), a device or an output.
  std::filesystem::path any_path(const YAML::Node& node, const std::string& field, const std::string& fix) const;

  // The folder path() keeps paths in: the document's `root:` (read_root), else the constructor's
  // root, else the file's folder.
  std::filesystem::path root() const;
  // Takes the top-level `root: FOLDER` of a config (relative to the file unless absolute), when
  // the document has one; the config's reader lists "root" among its keys.
  void read_root(const YAML::Node& document);

  const std::filesystem::path& file() const { return file_; }

 private:
  std::filesystem::path file_;
  std::filesystem::path root_;
};

// Whether `path` is `folder` or lies under it, by their names (absolute and normal).
bool contains(const std::filesystem::path& folder, const std::filesystem::path& path);

}  // namespace skylit
