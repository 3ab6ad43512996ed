#pragma once
// Reading back the CSV files a run writes (output/csv_writer.hpp: a header of names with units,
// then rows of numbers written as the shortest text that reads back to the same double): a
// restart resumes a test's curves from them, a study gathers its runs' curves.

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace yarnsim::output {

/// A CSV file as text: its header and the cells of each row.
struct CsvTable {
  std::filesystem::path file;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  /// The index of a column, -1 when the file has none of that name.
  std::ptrdiff_t column(std::string_view name) const;
  /// A column's values, "nan" read as NaN (NaN for every row when the file has no such column).
  /// Throws std::runtime_error (file, row, column, the cell) for a cell that is not a number.
  std::vector<double> numbers(std::string_view name) const;
};

/// Reads `file`: its header and at most `max_rows` rows (all when negative). Throws
/// std::runtime_error when the file cannot be read or a row has another number of cells than
/// the header.
CsvTable read_csv_table(const std::filesystem::path& file, long max_rows = -1);

} // namespace yarnsim::output
