#pragma once
// Time histories as CSV (monitors, run statistics): a header naming each column with its unit,
// then one row of numbers per call, flushed at once so a crashed or killed run loses nothing.

#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <vector>

namespace yarnsim::output {

class CsvWriter {
public:
  /// Creates (truncating) file, and its parent directory if needed, and writes the header, e.g.
  /// {"time [s]", "x [m]"} -> "time [s],x [m]". Throws std::invalid_argument for no columns or a
  /// column containing a comma, quote or line break; std::runtime_error if the file cannot be
  /// written.
  CsvWriter(const std::filesystem::path& file, std::vector<std::string> columns_with_units);
  /// Goes on with file as an earlier run of the same model left it (a restart): keeps its header,
  /// which must name the same columns (any when columns_with_units is empty), and its first
  /// keep_rows rows, drops any later ones (rewritten through file.tmp and a rename), then
  /// appends. Throws std::runtime_error when the file is missing, has another header or fewer
  /// complete rows.
  CsvWriter(const std::filesystem::path& file, std::vector<std::string> columns_with_units,
            long keep_rows);

  /// Appends one row (shortest decimal text that reads back to the same double) and flushes it
  /// to the operating system. Throws std::invalid_argument if values.size() differs from the
  /// number of columns, std::runtime_error if the write fails.
  void row(std::span<const double> values);
  /// Appends one row of cells already formatted (numbers, names) and flushes it. Throws
  /// std::invalid_argument if cells.size() differs from the number of columns or a cell contains
  /// a comma, quote or line break, std::runtime_error if the write fails.
  void row(std::span<const std::string> cells);

  const std::filesystem::path& path() const { return path_; }
  std::size_t columns() const { return columns_; }
  /// Rows in the file (without the header).
  long rows() const { return rows_; }

private:
  void write_line(const std::string& line);

  std::filesystem::path path_;
  std::size_t columns_ = 0;
  long rows_ = 0;
  std::ofstream out_;
};

} // namespace yarnsim::output
