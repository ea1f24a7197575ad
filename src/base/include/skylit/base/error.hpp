#pragma once
// Errors a user can cause. Each message names the file, the field (or line) and the fix.
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

namespace skylit {

// Bad input: a config, a model, a bake directory, a command-line value.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// "FILE:LINE:COL: field 'FIELD': PROBLEM. Fix: FIX" (line/col omitted when < 0; 1-based).
std::string input_message(const std::filesystem::path& file, int line, int column,
                          const std::string& field, const std::string& problem,
                          const std::string& fix);

// The fix for an unknown key in a config file: "did you mean 'resolution'? (allowed: a, b, c)"
// when a known key is within a few edits (case-insensitive), "remove it (allowed: ...)" otherwise.
std::string unknown_key_fix(std::string_view key, std::span<const std::string_view> allowed);

}  // namespace skylit
