#pragma once
// Errors a user can cause. Each message names the file, the field (or line) and the fix.
#include <filesystem>
#include <stdexcept>
#include <string>

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

}  // namespace skylit
