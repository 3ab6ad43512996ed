#include "engine/output/csv_reader.hpp"

#include <algorithm>
#include <charconv>
#include <fmt/format.h>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace yarnsim::output {

namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream stream(line);
  for (std::string cell; std::getline(stream, cell, ',');)
    cells.push_back(cell);
  if (!line.empty() && line.back() == ',')
    cells.emplace_back();
  return cells;
}

} // namespace

std::ptrdiff_t CsvTable::column(std::string_view name) const {
  const auto it = std::find(header.begin(), header.end(), name);
  return it == header.end() ? -1 : it - header.begin();
}

std::vector<double> CsvTable::numbers(std::string_view name) const {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> out(rows.size(), kNaN);
  const std::ptrdiff_t c = column(name);
  if (c < 0)
    return out;
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const std::string& cell = rows[r][static_cast<std::size_t>(c)];
    double v = kNaN;
    const auto [end, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), v);
    if (ec != std::errc() || end != cell.data() + cell.size())
      throw std::runtime_error(fmt::format("{}: row {}, column '{}': expected a number, found "
                                           "'{}'",
                                           file.string(), r + 1, name, cell));
    out[r] = v;
  }
  return out;
}

CsvTable read_csv_table(const std::filesystem::path& file, long max_rows) {
  std::ifstream in(file);
  CsvTable table{file, {}, {}};
  std::string line;
  if (!in || !std::getline(in, line))
    throw std::runtime_error(fmt::format("cannot read {}", file.string()));
  table.header = split(line);
  while ((max_rows < 0 || static_cast<long>(table.rows.size()) < max_rows) &&
         std::getline(in, line)) {
    table.rows.push_back(split(line));
    if (table.rows.back().size() != table.header.size())
      throw std::runtime_error(fmt::format("{}: row {} has {} cells, the header {}", file.string(),
                                           table.rows.size(), table.rows.back().size(),
                                           table.header.size()));
  }
  return table;
}

} // namespace yarnsim::output
