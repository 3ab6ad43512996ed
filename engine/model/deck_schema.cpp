#include "engine/model/deck_schema.hpp"

#include <algorithm>
#include <cassert>
#include <cctype>
#include <cmath>
#include <fmt/format.h>
#include <numeric>

namespace yarnsim::deck {

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

/// A double as a reader would write it: 16.0 stays "16.0" so it does not pass for an integer.
std::string format_number(double v) {
  if (std::isfinite(v) && v == std::floor(v) && std::abs(v) < 1e15)
    return fmt::format("{:.1f}", v);
  return fmt::format("{}", v);
}

double as_double(const toml::node& n) {
  if (const auto* i = n.as_integer())
    return static_cast<double>(i->get());
  return n.as_floating_point()->get();
}

std::string_view expected_text(Type type) {
  switch (type) {
  case Type::String:
    return "a string";
  case Type::Integer:
    return "an integer";
  case Type::Number:
    return "a number";
  case Type::Boolean:
    return "a boolean (true or false)";
  case Type::Vector3:
    return "an array of 3 numbers [x, y, z]";
  case Type::Labels:
    return "an array of node labels [n, ...]";
  case Type::Triples:
    return "an array of node label triples [[first, middle, last], ...]";
  case Type::Points:
    return "an array of points [[x, y, z], ...]";
  case Type::TimeTable:
    return "a time table [[t, value], ...]";
  case Type::Words:
    return "a string or an array of strings";
  case Type::Table:
    return "a table";
  case Type::Tables:
    return "an array of tables";
  case Type::Any:
    return "a value";
  }
  return "a value";
}

std::string with_range(std::string_view what, const Range& range) {
  return range.bounded() ? fmt::format("{} {}", what, range.describe()) : std::string(what);
}

} // namespace

void Diagnostics::error(const toml::source_region& where, std::string_view path,
                        std::string_view message) {
  const toml::source_index line = where.begin.line == 0 ? 1 : where.begin.line;
  const toml::source_index column = where.begin.line == 0 ? 1 : where.begin.column;
  entries_.push_back({line, column,
                      fmt::format("{}:{}:{}: {}{}{}", source_, line, column, path,
                                  path.empty() ? "" : ": ", message)});
}

void Diagnostics::attach(const toml::source_region& where, std::string text) {
  const toml::source_index line = where.begin.line == 0 ? 1 : where.begin.line;
  const toml::source_index column = where.begin.line == 0 ? 1 : where.begin.column;
  entries_.push_back({line, column, std::move(text)});
}

std::vector<std::string> Diagnostics::messages() const {
  std::vector<std::size_t> order(entries_.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t i, std::size_t j) {
    const Entry& a = entries_[i];
    const Entry& b = entries_[j];
    return a.line != b.line ? a.line < b.line : a.column < b.column;
  });
  std::vector<std::string> out;
  for (std::size_t i : order)
    if (std::find(out.begin(), out.end(), entries_[i].text) == out.end())
      out.push_back(entries_[i].text);
  return out;
}

std::string Range::describe() const {
  if (lo == -kInf && hi == kInf)
    return {};
  if (hi == kInf)
    return fmt::format("{} {}", lo_open ? ">" : ">=", lo);
  if (lo == -kInf)
    return fmt::format("{} {}", hi_open ? "<" : "<=", hi);
  return fmt::format("in {}{}, {}{}", lo_open ? "(" : "[", lo, hi, hi_open ? ")" : "]");
}

const KeySpec* TableSpec::find(std::string_view key) const {
  for (const KeySpec& k : keys)
    if (k.name == key)
      return &k;
  return nullptr;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  const std::size_t n = a.size();
  const std::size_t m = b.size();
  std::vector<std::size_t> d((n + 1) * (m + 1));
  auto at = [&](std::size_t i, std::size_t j) -> std::size_t& { return d[i * (m + 1) + j]; };
  for (std::size_t i = 0; i <= n; ++i)
    at(i, 0) = i;
  for (std::size_t j = 0; j <= m; ++j)
    at(0, j) = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      at(i, j) = std::min({at(i - 1, j) + 1, at(i, j - 1) + 1, at(i - 1, j - 1) + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        at(i, j) = std::min(at(i, j), at(i - 2, j - 2) + 1);
    }
  }
  return at(n, m);
}

std::string_view closest(std::string_view word, std::span<const std::string_view> candidates) {
  const std::string w = lower(word);
  // Allow more typos in longer words, never as many as the word has letters.
  const std::size_t allowed = w.size() <= 4 ? 1 : w.size() <= 8 ? 2 : 3;
  std::string_view best;
  std::size_t best_distance = allowed + 1;
  for (std::string_view c : candidates) {
    const std::size_t dist = edit_distance(w, lower(c));
    if (dist < best_distance && (dist == 0 || dist < w.size())) {
      best = c;
      best_distance = dist;
    }
  }
  return best;
}

std::string describe_found(const toml::node& node) {
  switch (node.type()) {
  case toml::node_type::string: {
    std::string_view s = node.as_string()->get();
    if (s.size() > 40)
      return fmt::format("a string \"{}...\"", s.substr(0, 37));
    return fmt::format("a string \"{}\"", s);
  }
  case toml::node_type::integer:
    return fmt::format("an integer ({})", node.as_integer()->get());
  case toml::node_type::floating_point:
    return fmt::format("a floating-point number ({})",
                       format_number(node.as_floating_point()->get()));
  case toml::node_type::boolean:
    return fmt::format("a boolean ({})", node.as_boolean()->get());
  case toml::node_type::table:
    return "a table";
  case toml::node_type::array: {
    const auto& a = *node.as_array();
    if (a.empty())
      return "an empty array";
    if (a.is_array_of_tables())
      return fmt::format("an array of {} tables", a.size());
    return fmt::format("an array of {} element{}", a.size(), a.size() == 1 ? "" : "s");
  }
  case toml::node_type::date:
    return "a date";
  case toml::node_type::time:
    return "a time";
  case toml::node_type::date_time:
    return "a date-time";
  case toml::node_type::none:
    break;
  }
  return "nothing";
}

CheckedTable::CheckedTable(const toml::table& table, const TableSpec& spec, std::string path,
                           Diagnostics& diagnostics, const toml::source_region& fallback)
    : table_(&table), spec_(&spec), path_(std::move(path)), diagnostics_(&diagnostics),
      source_(table.source().begin.line != 0 ? table.source() : fallback) {
  std::vector<std::string_view> names;
  for (const KeySpec& k : spec.keys)
    names.push_back(k.name);

  for (auto&& [key, value] : table) {
    const KeySpec* k = spec.find(key.str());
    if (k == nullptr) {
      const std::string_view suggestion = closest(key.str(), names);
      std::string message = fmt::format("unknown key '{}' in {}", key.str(), spec.title);
      if (!suggestion.empty()) {
        message += fmt::format("; did you mean '{}'?", suggestion);
        suggested_.emplace_back(suggestion);
      } else
        message += fmt::format("; known keys: {}", fmt::join(names, ", "));
      const auto& where = key.source().begin.line != 0 ? key.source() : source_;
      diagnostics.error(where, this->path(key.str()), message);
      continue;
    }
    if (check_value(*k, value))
      valid_.emplace_back(k->name);
  }
  for (const KeySpec& k : spec.keys)
    if (k.need == kRequired && !table.contains(k.name))
      missing(k.name, with_range(expected_text(k.type), k.range));
}

bool CheckedTable::misspelt(std::string_view key) const {
  return std::find(suggested_.begin(), suggested_.end(), key) != suggested_.end();
}

void CheckedTable::missing(std::string_view key, std::string_view what) const {
  if (!misspelt(key))
    error(fmt::format("missing required key '{}' ({})", key, what));
}

std::string CheckedTable::path(std::string_view key) const {
  return path_.empty() ? std::string(key) : fmt::format("{}.{}", path_, key);
}

const toml::source_region& CheckedTable::source(std::string_view key) const {
  const toml::node* n = node(key);
  return n != nullptr && n->source().begin.line != 0 ? n->source() : source_;
}

const toml::source_region& CheckedTable::source(std::string_view key, std::size_t i) const {
  const toml::node* n = node(key);
  if (n != nullptr && n->is_array() && i < n->as_array()->size()) {
    const toml::node* item = n->as_array()->get(i);
    if (item->source().begin.line != 0)
      return item->source();
  }
  return source(key);
}

const toml::node* CheckedTable::node(std::string_view key) const {
  return table_->get(key);
}

bool CheckedTable::valid(std::string_view key) const {
  return std::find(valid_.begin(), valid_.end(), key) != valid_.end();
}

const KeySpec& CheckedTable::spec_of(std::string_view key) const {
  const KeySpec* k = spec_->find(key);
  assert(k != nullptr && "key missing from the block's schema");
  return *k;
}

void CheckedTable::error(std::string_view key, std::string_view message) const {
  diagnostics_->error(source(key), path(key), message);
}

void CheckedTable::error(std::string_view key, std::size_t i, std::string_view message) const {
  diagnostics_->error(source(key, i), fmt::format("{}[{}]", path(key), i), message);
}

void CheckedTable::error(std::string_view message) const {
  diagnostics_->error(source_, path_, message);
}

bool CheckedTable::check_number(const toml::node& node, const KeySpec& key, std::string_view path,
                                bool integer) {
  const auto where = node.source().begin.line != 0 ? node.source() : source_;
  const std::string expected = with_range(integer ? "an integer" : "a number", key.range);
  if (integer ? !node.is_integer() : !node.is_number()) {
    diagnostics_->error(where, path,
                        fmt::format("expected {}, found {}", expected, describe_found(node)));
    return false;
  }
  const double v = as_double(node);
  if (!std::isfinite(v)) {
    diagnostics_->error(where, path, fmt::format("expected a finite number, found {}", v));
    return false;
  }
  if (!key.range.contains(v)) {
    diagnostics_->error(where, path,
                        fmt::format("expected {}, found {}", expected,
                                    node.is_integer() ? fmt::format("{}", node.as_integer()->get())
                                                      : format_number(v)));
    return false;
  }
  return true;
}

bool CheckedTable::check_value(const KeySpec& key, const toml::node& value) {
  const std::string p = path(key.name);
  auto wrong_type = [&](std::string_view expected) {
    error(key.name, fmt::format("expected {}, found {}", expected, describe_found(value)));
    return false;
  };
  auto item_path = [&](std::size_t i) { return fmt::format("{}[{}]", p, i); };
  // A non-empty array, or a report that it is not one.
  auto nonempty_array = [&]() -> const toml::array* {
    const toml::array* a = value.as_array();
    if (a == nullptr || a->empty()) {
      wrong_type(expected_text(key.type));
      return nullptr;
    }
    return a;
  };
  // An array of exactly n numbers (integers when `integer`) for item i of an array.
  auto fixed_row = [&](const toml::node& row, std::string_view row_path, std::size_t n,
                       bool integer, std::string_view what) {
    const toml::array* r = row.as_array();
    if (r == nullptr || r->size() != n) {
      diagnostics_->error(row.source().begin.line != 0 ? row.source() : source(key.name), row_path,
                          fmt::format("expected {}, found {}", what, describe_found(row)));
      return false;
    }
    bool ok = true;
    for (std::size_t j = 0; j < n; ++j)
      ok = check_number(*r->get(j), key, fmt::format("{}[{}]", row_path, j), integer) && ok;
    return ok;
  };

  switch (key.type) {
  case Type::String:
    return value.is_string() || wrong_type("a string");
  case Type::Boolean:
    return value.is_boolean() || wrong_type("a boolean (true or false)");
  case Type::Integer:
    return check_number(value, key, p, true);
  case Type::Number:
    return check_number(value, key, p, false);
  case Type::Vector3:
    return fixed_row(value, p, 3, false, expected_text(key.type));
  case Type::Labels: {
    const toml::array* a = nonempty_array();
    if (a == nullptr)
      return false;
    bool ok = true;
    for (std::size_t i = 0; i < a->size(); ++i)
      ok = check_number(*a->get(i), key, item_path(i), true) && ok;
    return ok;
  }
  case Type::Triples:
  case Type::Points: {
    const toml::array* a = nonempty_array();
    if (a == nullptr)
      return false;
    const bool integer = key.type == Type::Triples;
    const std::string_view what =
        integer ? "an array of 3 node labels [first, middle, last]" : "an array of 3 numbers";
    bool ok = true;
    for (std::size_t i = 0; i < a->size(); ++i)
      ok = fixed_row(*a->get(i), item_path(i), 3, integer, what) && ok;
    return ok;
  }
  case Type::TimeTable: {
    const toml::array* a = nonempty_array();
    if (a == nullptr)
      return false;
    bool ok = true;
    double previous = -kInf;
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& row = *a->get(i);
      if (!fixed_row(row, item_path(i), 2, false, "a row [time, value] of 2 numbers")) {
        ok = false;
        continue;
      }
      const toml::node& t_node = *row.as_array()->get(0);
      const double t = as_double(t_node);
      const std::string t_path = fmt::format("{}[0]", item_path(i));
      if (t < 0) {
        diagnostics_->error(t_node.source(), t_path,
                            fmt::format("expected a time >= 0, found {}", format_number(t)));
        ok = false;
      } else if (t <= previous) {
        diagnostics_->error(t_node.source(), t_path,
                            fmt::format("expected a time > {} (times must increase), found {}",
                                        format_number(previous), format_number(t)));
        ok = false;
      }
      previous = std::max(previous, t);
    }
    return ok;
  }
  case Type::Words: {
    if (value.is_string())
      return true;
    const toml::array* a = value.as_array();
    if (a == nullptr || a->empty())
      return wrong_type(expected_text(key.type));
    bool ok = true;
    for (std::size_t i = 0; i < a->size(); ++i) {
      if (!a->get(i)->is_string()) {
        diagnostics_->error(source(key.name, i), item_path(i),
                            fmt::format("expected a string, found {}", describe_found(*a->get(i))));
        ok = false;
      }
    }
    return ok;
  }
  case Type::Table: {
    if (!value.is_table())
      return wrong_type("a table");
    assert(key.sub != nullptr);
    children_.emplace_back(std::string(key.name), std::vector<CheckedTable>{});
    children_.back().second.emplace_back(*value.as_table(), *key.sub, p, *diagnostics_,
                                         source(key.name));
    return true;
  }
  case Type::Tables: {
    const toml::array* a = value.as_array();
    if (a == nullptr)
      return wrong_type(fmt::format("an array of tables ([[{}]])", key.name));
    assert(key.sub != nullptr);
    std::vector<CheckedTable> items;
    bool ok = true;
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& item = *a->get(i);
      if (!item.is_table()) {
        diagnostics_->error(source(key.name, i), item_path(i),
                            fmt::format("expected a table, found {}", describe_found(item)));
        ok = false;
        continue;
      }
      items.emplace_back(*item.as_table(), *key.sub, item_path(i), *diagnostics_,
                         source(key.name, i));
    }
    children_.emplace_back(std::string(key.name), std::move(items));
    return ok;
  }
  case Type::Any:
    return true;
  }
  return false;
}

std::optional<std::string> CheckedTable::string(std::string_view key) const {
  assert(spec_of(key).type == Type::String);
  if (!valid(key))
    return std::nullopt;
  return std::string(node(key)->as_string()->get());
}

std::optional<double> CheckedTable::number(std::string_view key) const {
  assert(spec_of(key).type == Type::Number);
  if (!valid(key))
    return std::nullopt;
  return as_double(*node(key));
}

std::optional<long long> CheckedTable::integer(std::string_view key) const {
  assert(spec_of(key).type == Type::Integer);
  if (!valid(key))
    return std::nullopt;
  return node(key)->as_integer()->get();
}

std::optional<bool> CheckedTable::boolean(std::string_view key) const {
  assert(spec_of(key).type == Type::Boolean);
  if (!valid(key))
    return std::nullopt;
  return node(key)->as_boolean()->get();
}

std::optional<Eigen::Vector3d> CheckedTable::vector3(std::string_view key) const {
  assert(spec_of(key).type == Type::Vector3);
  if (!valid(key))
    return std::nullopt;
  const toml::array& a = *node(key)->as_array();
  return Eigen::Vector3d(as_double(*a.get(0)), as_double(*a.get(1)), as_double(*a.get(2)));
}

std::optional<std::vector<long long>> CheckedTable::labels(std::string_view key) const {
  assert(spec_of(key).type == Type::Labels);
  if (!valid(key))
    return std::nullopt;
  std::vector<long long> out;
  for (const toml::node& n : *node(key)->as_array())
    out.push_back(n.as_integer()->get());
  return out;
}

std::optional<std::vector<std::array<long long, 3>>>
CheckedTable::triples(std::string_view key) const {
  assert(spec_of(key).type == Type::Triples);
  if (!valid(key))
    return std::nullopt;
  std::vector<std::array<long long, 3>> out;
  for (const toml::node& row : *node(key)->as_array()) {
    const toml::array& r = *row.as_array();
    out.push_back({r.get(0)->as_integer()->get(), r.get(1)->as_integer()->get(),
                   r.get(2)->as_integer()->get()});
  }
  return out;
}

std::optional<std::vector<Eigen::Vector3d>> CheckedTable::points(std::string_view key) const {
  assert(spec_of(key).type == Type::Points);
  if (!valid(key))
    return std::nullopt;
  std::vector<Eigen::Vector3d> out;
  for (const toml::node& row : *node(key)->as_array()) {
    const toml::array& r = *row.as_array();
    out.emplace_back(as_double(*r.get(0)), as_double(*r.get(1)), as_double(*r.get(2)));
  }
  return out;
}

std::optional<TimeTable> CheckedTable::time_table(std::string_view key) const {
  assert(spec_of(key).type == Type::TimeTable);
  if (!valid(key))
    return std::nullopt;
  TimeTable t;
  for (const toml::node& row : *node(key)->as_array()) {
    t.time.push_back(as_double(*row.as_array()->get(0)));
    t.value.push_back(as_double(*row.as_array()->get(1)));
  }
  return t;
}

std::optional<std::vector<std::string>> CheckedTable::words(std::string_view key) const {
  assert(spec_of(key).type == Type::Words);
  if (!valid(key))
    return std::nullopt;
  const toml::node& n = *node(key);
  if (n.is_string())
    return std::vector<std::string>{std::string(n.as_string()->get())};
  std::vector<std::string> out;
  for (const toml::node& w : *n.as_array())
    out.emplace_back(w.as_string()->get());
  return out;
}

const CheckedTable* CheckedTable::table(std::string_view key) const {
  assert(spec_of(key).type == Type::Table);
  for (const auto& [name, items] : children_)
    if (name == key && !items.empty())
      return &items.front();
  return nullptr;
}

std::span<const CheckedTable> CheckedTable::tables(std::string_view key) const {
  assert(spec_of(key).type == Type::Tables);
  for (const auto& [name, items] : children_)
    if (name == key)
      return items;
  return {};
}

} // namespace yarnsim::deck
