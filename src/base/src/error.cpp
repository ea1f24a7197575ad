#include "skylit/base/error.hpp"

namespace skylit {

std::string input_message(const std::filesystem::path& file, int line, int column,
                          const std::string& field, const std::string& problem,
                          const std::string& fix) {
  std::string message;
  if (!file.empty()) {
    message += file.string();
    if (line > 0) {
      message += ':' + std::to_string(line);
      if (column > 0) message += ':' + std::to_string(column);
    }
    message += ": ";
  }
  if (!field.empty()) message += "field '" + field + "': ";
  message += problem;
  // One full stop between the problem and the fix, whether or not the caller wrote one.
  if (!message.empty() && message.back() != '.') message += '.';
  if (!fix.empty()) message += " Fix: " + fix;
  return message;
}

}  // namespace skylit
