#include "engine/output/csv_writer.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace yarnsim::output {

CsvWriter::CsvWriter(const std::filesystem::path& file, std::vector<std::string> columns_with_units)
    : path_(file), columns_(columns_with_units.size()) {
  if (columns_with_units.empty())
    throw std::invalid_argument(fmt::format("csv: {} needs at least one column", file.string()));
  for (const std::string& column : columns_with_units)
    if (column.find_first_of(",\"\r\n") != std::string::npos)
      throw std::invalid_argument(fmt::format(
          "csv: column '{}' of {} contains a comma, quote or line break", column, file.string()));
  if (file.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(file.parent_path(), ec);
    if (ec)
      throw std::runtime_error(fmt::format("csv: cannot create directory {}: {}",
                                           file.parent_path().string(), ec.message()));
  }
  out_.open(file, std::ios::trunc);
  out_ << fmt::format("{}\n", fmt::join(columns_with_units, ",")) << std::flush;
  if (!out_)
    throw std::runtime_error(fmt::format("csv: cannot write {}", file.string()));
}

CsvWriter::CsvWriter(const std::filesystem::path& file, std::vector<std::string> columns_with_units,
                     long keep_rows)
    : path_(file), columns_(columns_with_units.size()) {
  std::string text;
  {
    std::ifstream in(file, std::ios::binary);
    if (!in)
      throw std::runtime_error(
          fmt::format("csv: cannot continue {}: the file is missing", file.string()));
    std::ostringstream s;
    s << in.rdbuf();
    text = s.str();
  }
  std::string header;
  if (columns_with_units.empty()) { // the file's own header
    const std::size_t eol = text.find('\n');
    if (eol == std::string::npos)
      throw std::runtime_error(
          fmt::format("csv: cannot continue {}: it has no complete header", file.string()));
    header = text.substr(0, eol + 1);
    columns_ = static_cast<std::size_t>(std::count(header.begin(), header.end(), ',')) + 1;
  } else {
    header = fmt::format("{}\n", fmt::join(columns_with_units, ","));
    if (text.compare(0, header.size(), header) != 0)
      throw std::runtime_error(fmt::format("csv: cannot continue {}: its header is not '{}'",
                                           file.string(), header.substr(0, header.size() - 1)));
  }
  // The end of row keep_rows: complete rows only.
  std::size_t end = header.size();
  for (long r = 0; r < keep_rows; ++r) {
    const std::size_t eol = text.find('\n', end);
    if (eol == std::string::npos)
      throw std::runtime_error(fmt::format("csv: cannot continue {}: it holds {} complete rows, "
                                           "the checkpoint {}",
                                           file.string(), r, keep_rows));
    end = eol + 1;
  }
  if (end != text.size()) {
    std::filesystem::path tmp = file;
    tmp += ".tmp";
    {
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      out.write(text.data(), static_cast<std::streamsize>(end));
      out.close();
      if (!out)
        throw std::runtime_error(fmt::format("csv: cannot write {}", tmp.string()));
    }
    std::error_code ec;
    std::filesystem::rename(tmp, file, ec);
    if (ec)
      throw std::runtime_error(fmt::format("csv: cannot rename {} to {}: {}", tmp.string(),
                                           file.string(), ec.message()));
  }
  rows_ = keep_rows;
  out_.open(file, std::ios::app);
  if (!out_)
    throw std::runtime_error(fmt::format("csv: cannot write {}", file.string()));
}

void CsvWriter::row(std::span<const double> values) {
  if (values.size() != columns_)
    throw std::invalid_argument(fmt::format("csv: row of {} values for the {} columns of {}",
                                            values.size(), columns_, path_.string()));
  write_line(fmt::format("{}\n", fmt::join(values, ",")));
}

void CsvWriter::row(std::span<const std::string> cells) {
  if (cells.size() != columns_)
    throw std::invalid_argument(fmt::format("csv: row of {} cells for the {} columns of {}",
                                            cells.size(), columns_, path_.string()));
  for (const std::string& cell : cells)
    if (cell.find_first_of(",\"\r\n") != std::string::npos)
      throw std::invalid_argument(fmt::format(
          "csv: cell '{}' for {} contains a comma, quote or line break", cell, path_.string()));
  write_line(fmt::format("{}\n", fmt::join(cells, ",")));
}

void CsvWriter::write_line(const std::string& line) {
  out_ << line << std::flush;
  if (!out_)
    throw std::runtime_error(fmt::format("csv: cannot write to {}", path_.string()));
  ++rows_;
}

} // namespace yarnsim::output
