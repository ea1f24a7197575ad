#pragma once
// Comma-separated rows (frame timestamps, pose tracks): fields with their 1-based
// columns (for messages), double quotes around a field allowed, blank lines and lines starting
// with '#' skipped.
#include <optional>
#include <string>
#include <vector>

namespace skylit {

struct CsvField {
  std::string text;  // trimmed of spaces, quotes removed
  int column = 1;    // 1-based character column where the field starts
};

struct CsvRow {
  int line = 0;  // 1-based
  std::vector<CsvField> fields;
};

// All rows of `text`. An unterminated quote is reported through `error` (line, column, text)
// and ends the parse.
struct CsvError {
  int line = 0;
  int column = 0;
  std::string problem;
};
std::vector<CsvRow> parse_csv(const std::string& text, CsvError* error);

// The whole field as a finite number ("1.5", "-2e3"), or nullopt.
std::optional<double> parse_number(const std::string& text);

}  // namespace skylit
