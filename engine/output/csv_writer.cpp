#include "engine/output/csv_writer.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

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

void CsvWriter::row(std::span<const double> values) {
  if (values.size() != columns_)
    throw std::invalid_argument(fmt::format("csv: row of {} values for the {} columns of {}",
                                            values.size(), columns_, path_.string()));
  std::string line = fmt::format("{}\n", fmt::join(values, ","));
  out_ << line << std::flush;
  if (!out_)
    throw std::runtime_error(fmt::format("csv: cannot write to {}", path_.string()));
}

} // namespace yarnsim::output
