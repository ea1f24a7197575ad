#include "skylit/base/error.hpp"

#include <algorithm>
#include <cctype>
#include <limits>
#include <vector>

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

namespace {

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      const bool same = std::tolower(static_cast<unsigned char>(a[i - 1])) ==
                        std::tolower(static_cast<unsigned char>(b[j - 1]));
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (same ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace

std::string unknown_key_fix(std::string_view key, std::span<const std::string_view> allowed) {
  std::string_view best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  std::string allowed_list;
  for (std::string_view candidate : allowed) {
    const std::size_t d = edit_distance(key, candidate);
    if (d < best_distance) {
      best_distance = d;
      best = candidate;
    }
    if (!allowed_list.empty()) allowed_list += ", ";
    allowed_list += candidate;
  }
  const std::size_t tolerance = std::max<std::size_t>(2, best.size() / 3);
  return best_distance <= tolerance ? "did you mean '" + std::string(best) + "'? (allowed: " + allowed_list + ")"
                                    : "remove it (allowed: " + allowed_list + ")";
}

}  // namespace skylit
