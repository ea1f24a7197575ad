#include "skylit/base/csv.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace skylit {
namespace {

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return {};
  const auto last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

}  // namespace

std::vector<CsvRow> parse_csv(const std::string& text, CsvError* error) {
  std::vector<CsvRow> rows;
  std::size_t pos = 0;
  int line = 0;
  while (pos < text.size()) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    const std::string content = text.substr(pos, end - pos);
    pos = end + 1;
    ++line;
    const std::string trimmed = trim(content);
    if (trimmed.empty() || trimmed.front() == '#') continue;
    CsvRow row;
    row.line = line;
    std::size_t i = 0;
    while (true) {
      CsvField field;
      field.column = static_cast<int>(i) + 1;
      std::string value;
      // Leading spaces, then a quoted or a plain field.
      std::size_t k = i;
      while (k < content.size() && (content[k] == ' ' || content[k] == '\t')) ++k;
      if (k < content.size() && content[k] == '"') {
        field.column = static_cast<int>(k) + 1;
        ++k;
        bool closed = false;
        while (k < content.size()) {
          if (content[k] == '"') {
            if (k + 1 < content.size() && content[k + 1] == '"') {
              value += '"';
              k += 2;
              continue;
            }
            closed = true;
            ++k;
            break;
          }
          value += content[k++];
        }
        if (!closed) {
          if (error) *error = CsvError{line, field.column, "a quote is not closed"};
          return rows;
        }
        const std::size_t comma = content.find(',', k);
        i = comma == std::string::npos ? content.size() : comma;
        field.text = value;
      } else {
        const std::size_t comma = content.find(',', i);
        const std::size_t stop = comma == std::string::npos ? content.size() : comma;
        field.text = trim(content.substr(i, stop - i));
        i = stop;
      }
      row.fields.push_back(std::move(field));
      if (i >= content.size()) break;
      ++i;  // past the comma
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

std::optional<double> parse_number(const std::string& text) {
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if (first != last && *first == '+') ++first;
  double value = 0;
  const auto [end, error] = std::from_chars(first, last, value);
  if (error != std::errc() || end != last || first == last || !std::isfinite(value)) return std::nullopt;
  return value;
}

}  // namespace skylit
