#pragma once
// Schema-driven checking of the TOML model deck. Every block declares its keys in a table of
// KeySpec (name, type, required or optional, range); CheckedTable walks a TOML table against such
// a spec, reports unknown keys (with a suggestion), missing keys, wrong types and out-of-range
// values to Diagnostics, and then hands out only values that passed. Cross-field rules and
// references between blocks are the builder's job (deck.cpp).

#include "engine/model/model.hpp"

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <toml++/toml.h>
#include <utility>
#include <vector>

namespace yarnsim::deck {

/// Collects the problems of one deck, each as "file:line:col: path: message".
class Diagnostics {
public:
  explicit Diagnostics(std::string source) : source_(std::move(source)) {}

  /// Records a problem at `where` (a region without a line is reported at 1:1). `path` is the
  /// key path of the offending node ("sections[0].EA"); empty for whole-file problems.
  void error(const toml::source_region& where, std::string_view path, std::string_view message);
  /// Records a message of another file the deck names (a TexGen file: "other.tg3:7:48: ..."),
  /// as written, listed after the deck's own messages at `where` (the key naming the file).
  void attach(const toml::source_region& where, std::string text);

  bool empty() const { return entries_.empty(); }
  const std::string& source() const { return source_; }
  /// All messages in file order (line, then column, then order of discovery), duplicates removed.
  std::vector<std::string> messages() const;

private:
  struct Entry {
    toml::source_index line;
    toml::source_index column;
    std::string text;
  };
  std::string source_;
  std::vector<Entry> entries_;
};

/// What a key's value must look like.
enum class Type {
  String,
  Integer,
  Number, ///< integer or floating point, finite
  Boolean,
  Vector3,   ///< [x, y, z] of numbers
  Labels,    ///< [n, ...] of integers (node labels), at least one
  Triples,   ///< [[first, middle, last], ...] of integers (element connectivity), at least one
  Points,    ///< [[x, y, z], ...] of numbers, at least one
  TimeTable, ///< [[t, value], ...] of numbers, t >= 0 strictly increasing, at least one row
  Words,     ///< a string or an array of strings
  Table,     ///< a table, checked against KeySpec::sub
  Tables,    ///< an array of tables ([[key]]), each checked against KeySpec::sub
  Any,       ///< left to the block's builder
};

inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// Closed or open interval a number (or each number of an array) must lie in.
struct Range {
  double lo = -kInf;
  double hi = kInf;
  bool lo_open = false;
  bool hi_open = false;

  bool contains(double v) const {
    return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  }
  bool bounded() const { return lo > -kInf || hi < kInf; }
  /// "> 0", ">= 1", "<= 2", "in (0, 0.5]"; empty when unbounded.
  std::string describe() const;
};

inline constexpr Range kAnyValue{};
inline constexpr Range kPositive{0, kInf, true, false};
inline constexpr Range kNonNegative{0, kInf, false, false};
inline constexpr Range kAtLeastOne{1, kInf, false, false};
// Ranges of quantities that both the model deck and the fabric deck read.
inline constexpr Range kPoisson{-1, 0.5, true, false};      ///< Poisson's ratio, in (-1, 0.5]
inline constexpr Range kNewmarkBeta{0, 0.5, true, false};   ///< Newmark beta, in (0, 0.5]
inline constexpr Range kNewmarkGamma{0.5, 1, false, false}; ///< Newmark gamma, in [0.5, 1]
inline constexpr Range kIterations{1, 1000, false, false};  ///< Newton iterations per increment

enum Need : bool { kOptional = false, kRequired = true };

struct TableSpec;

/// One key of a block.
struct KeySpec {
  std::string_view name;
  Type type;
  Need need = kOptional;
  Range range = kAnyValue;        ///< for numbers, and for each number of an array
  const TableSpec* sub = nullptr; ///< for Type::Table and Type::Tables
};

/// The keys of one block; `title` names the block in messages ("[[sections]]").
struct TableSpec {
  std::string_view title;
  std::span<const KeySpec> keys;

  const KeySpec* find(std::string_view key) const;
};

/// Edit distance (optimal string alignment: insert, delete, substitute, swap neighbours).
std::size_t edit_distance(std::string_view a, std::string_view b);

/// The candidate closest to `word` if it is close enough to be a likely misspelling (case
/// differences are free); empty when none is.
std::string_view closest(std::string_view word, std::span<const std::string_view> candidates);

/// "a string \"abc\"", "an integer (5)", "a table", "an array of 2 elements", ... for messages.
std::string describe_found(const toml::node& node);

/// A TOML table checked against its spec on construction. Accessors return a value only when the
/// key is present and passed its checks; otherwise std::nullopt (the problem is already reported).
class CheckedTable {
public:
  /// `path` is the key path of the table ("" for the root, "sections[0]", "steps[1].newmark");
  /// `fallback` is used as the position of a table that has none of its own (implicit tables).
  CheckedTable(const toml::table& table, const TableSpec& spec, std::string path,
               Diagnostics& diagnostics, const toml::source_region& fallback = {});

  /// Key path of the table, or of one of its keys.
  const std::string& path() const { return path_; }
  std::string path(std::string_view key) const;
  /// Position of the table, or of a key's value (the table's when the key is absent).
  const toml::source_region& source() const { return source_; }
  const toml::source_region& source(std::string_view key) const;
  /// Position of item i of an array-valued key (of the key when there is no such item).
  const toml::source_region& source(std::string_view key, std::size_t i) const;

  /// Present, whether or not its value passed.
  bool present(std::string_view key) const { return node(key) != nullptr; }
  /// Present and passed.
  bool valid(std::string_view key) const;
  const toml::node* node(std::string_view key) const;

  std::optional<std::string> string(std::string_view key) const;
  std::optional<double> number(std::string_view key) const;
  std::optional<long long> integer(std::string_view key) const;
  std::optional<bool> boolean(std::string_view key) const;
  std::optional<Eigen::Vector3d> vector3(std::string_view key) const;
  std::optional<std::vector<long long>> labels(std::string_view key) const;
  std::optional<std::vector<std::array<long long, 3>>> triples(std::string_view key) const;
  std::optional<std::vector<Eigen::Vector3d>> points(std::string_view key) const;
  std::optional<TimeTable> time_table(std::string_view key) const;
  std::optional<std::vector<std::string>> words(std::string_view key) const;
  /// A Type::Table key's checked table; nullptr when absent or not a table.
  const CheckedTable* table(std::string_view key) const;
  /// A Type::Tables key's checked tables; empty when absent or not an array of tables.
  std::span<const CheckedTable> tables(std::string_view key) const;

  /// True when an unknown key of this table was reported with `key` as its suggestion: the
  /// key is then misspelt rather than missing, and needs no second message.
  bool misspelt(std::string_view key) const;
  /// Reports a missing key at the table ("missing required key 'key' (what)"), unless misspelt.
  void missing(std::string_view key, std::string_view what) const;

  /// Reports a problem at a key's value (at the table when the key is absent).
  void error(std::string_view key, std::string_view message) const;
  /// Reports a problem at item i of an array-valued key, path "key[i]".
  void error(std::string_view key, std::size_t i, std::string_view message) const;
  /// Reports a problem with the table as a whole.
  void error(std::string_view message) const;
  Diagnostics& diagnostics() const { return *diagnostics_; }
  /// The spec the table was checked against.
  const TableSpec& spec() const { return *spec_; }

private:
  const KeySpec& spec_of(std::string_view key) const;
  bool check_value(const KeySpec& key, const toml::node& value);
  bool check_number(const toml::node& node, const KeySpec& key, std::string_view path,
                    bool integer);

  const toml::table* table_;
  const TableSpec* spec_;
  std::string path_;
  Diagnostics* diagnostics_;
  toml::source_region source_;
  std::vector<std::string> valid_;
  std::vector<std::string> suggested_;
  std::vector<std::pair<std::string, std::vector<CheckedTable>>> children_;
};

} // namespace yarnsim::deck
