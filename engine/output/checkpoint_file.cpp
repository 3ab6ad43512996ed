#include "engine/output/checkpoint_file.hpp"

#include "engine/output/hdf5.hpp"
#include "yarnsim/version.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <system_error>
#include <vector>

namespace yarnsim::output {
namespace {

constexpr const char* kFormat = "yarnsim checkpoint 1";
constexpr std::size_t kSurfacePairValues = 22; ///< columns of /surface_contact/pair_values

/// FNV-1a, 64 bits, over bytes.
struct Fnv1a {
  std::uint64_t h = 14695981039346656037ull;
  void add(const void* data, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
      h ^= p[i];
      h *= 1099511628211ull;
    }
  }
};

// ---- writing -------------------------------------------------------------------------------

/// A column-major rows x n matrix as a dataset of shape (n, rows): column by column.
template <int Rows>
void write_columns(hid_t group, const std::string& name,
                   const Eigen::Matrix<double, Rows, Eigen::Dynamic>& m) {
  const std::array<hsize_t, 2> dims{static_cast<hsize_t>(m.cols()), static_cast<hsize_t>(Rows)};
  h5::write_dataset(group, name, std::span<const double>(m.data(), m.size()), dims);
}

void write_table(hid_t group, const std::string& name, const std::vector<double>& values,
                 std::size_t columns) {
  const std::array<hsize_t, 2> dims{values.size() / columns, columns};
  h5::write_dataset(group, name, std::span<const double>(values), dims);
}

void write_table(hid_t group, const std::string& name, const std::vector<int>& values,
                 std::size_t columns) {
  const std::array<hsize_t, 2> dims{values.size() / columns, columns};
  h5::write_dataset(group, name, std::span<const int>(values), dims);
}

/// The torsional friction history of committed contact points (spline or surface: the same
/// fields): a table of (twist_anchor rad, twist_slip rad, twist state 0/1/2) per point.
template <class Committed>
void write_committed_twist(hid_t group, const std::vector<Committed>& committed) {
  std::vector<double> values;
  for (const Committed& w : committed)
    values.insert(values.end(), {w.twist_anchor, w.twist_slip, static_cast<double>(w.twist)});
  write_table(group, "committed_twist", values, 3);
}

void write_status(hid_t object, const std::string& prefix, const ExplicitStatus& s) {
  h5::write_double_attribute(object, prefix + "critical_dt", s.critical_dt);
  h5::write_double_attribute(object, prefix + "stable_dt", s.stable_dt);
  h5::write_string_attribute(object, prefix + "limited_by", s.limited_by);
  h5::write_double_attribute(object, prefix + "dt", s.dt);
  h5::write_double_attribute(object, prefix + "added_mass", s.added_mass);
  h5::write_double_attribute(object, prefix + "added_mass_percent", s.added_mass_percent);
  h5::write_double_attribute(object, prefix + "added_rotary_percent", s.added_rotary_percent);
  h5::write_double_attribute(object, prefix + "increments", static_cast<double>(s.increments));
}

/// Attribute `definitions` and a table boxes_<k> (n_segments, 6) per definition: min then max
/// corner of each segment's box at the definition's last search.
void write_search_boxes(hid_t g, const std::vector<std::vector<Eigen::AlignedBox3d>>& search) {
  h5::write_int_attribute(g, "definitions", static_cast<int>(search.size()));
  for (std::size_t k = 0; k < search.size(); ++k) {
    std::vector<double> boxes;
    boxes.reserve(6 * search[k].size());
    for (const Eigen::AlignedBox3d& b : search[k])
      boxes.insert(boxes.end(),
                   {b.min().x(), b.min().y(), b.min().z(), b.max().x(), b.max().y(), b.max().z()});
    write_table(g, fmt::format("boxes_{}", k), boxes, 6);
  }
}

void write_contact(hid_t parent, const SplineContactSet::Snapshot& c) {
  h5::Handle group = h5::create_group(parent, "contact");
  const hid_t g = group.id();
  h5::write_int_attribute(g, "candidates_version", c.candidates_version);
  write_search_boxes(g, c.search_boxes);
  std::vector<int> keys;
  std::vector<double> values;
  for (const auto& w : c.committed) {
    keys.insert(keys.end(), w.key.begin(), w.key.end());
    values.insert(values.end(), {w.xi_A, w.xi_B, w.active ? 1.0 : 0.0});
  }
  write_table(g, "committed_keys", keys, 3);
  write_table(g, "committed", values, 3);
  // Friction histories (anchor_A, anchor_B, slip, state) and the dissipated energy: written by
  // versions with friction; an older checkpoint has none (frictionless).
  values.clear();
  for (const auto& w : c.committed)
    values.insert(values.end(), {w.anchor_A, w.anchor_B, w.slip, static_cast<double>(w.friction)});
  write_table(g, "committed_friction", values, 4);
  h5::write_double_attribute(g, "friction_dissipated", c.dissipated);
  // Torsional friction: written by versions with it.
  write_committed_twist(g, c.committed);
  // Friction histories of the line contact's Gauss points (key: definition, slave segment, Gauss
  // point, master spline; values: anchor, slip, state): written by versions with it.
  keys.clear();
  values.clear();
  for (const auto& w : c.line_committed) {
    keys.insert(keys.end(), w.key.begin(), w.key.end());
    values.insert(values.end(), {w.anchor, w.slip, static_cast<double>(w.friction)});
  }
  write_table(g, "line_committed_keys", keys, 4);
  write_table(g, "line_committed", values, 3);
  keys.clear();
  values.clear();
  std::vector<int> flags;
  for (const auto& p : c.pairs) {
    keys.insert(keys.end(), p.key.begin(), p.key.end());
    flags.insert(flags.end(), {static_cast<int>(p.status), p.degenerate ? 1 : 0, p.active ? 1 : 0,
                               p.iterations});
    values.insert(values.end(), {p.xi_A, p.xi_B, p.distance, p.gap, p.penetration,
                                 p.penetration_rate, p.force, p.potential});
    for (const Eigen::Vector3d* v : {&p.point_A, &p.point_B, &p.normal})
      values.insert(values.end(), {v->x(), v->y(), v->z()});
  }
  write_table(g, "pair_keys", keys, 3);
  write_table(g, "pair_flags", flags, 4);
  write_table(g, "pair_values", values, 17);
}

void write_surface_contact(hid_t parent, const SurfaceContactSet::Snapshot& c) {
  h5::Handle group = h5::create_group(parent, "surface_contact");
  const hid_t g = group.id();
  h5::write_int_attribute(g, "candidates_version", c.candidates_version);
  write_search_boxes(g, c.search_boxes);
  const ContactSummary& m = c.summary;
  h5::write_int_attribute(g, "summary_candidates", m.candidates);
  h5::write_int_attribute(g, "summary_active", m.active);
  h5::write_double_attribute(g, "summary_active_share", m.active_share);
  h5::write_double_attribute(g, "summary_max_penetration", m.max_penetration);
  h5::write_double_attribute(g, "summary_max_force", m.max_force);
  h5::write_double_attribute(g, "summary_potential", m.potential);
  h5::write_double_attribute(g, "summary_total_force", m.total_force);
  h5::write_double_attribute(g, "summary_min_gap", m.min_gap);
  // Friction (written by versions with surface friction): the summary's figures, the histories
  // (anchor zeta_A, theta_A, zeta_B, theta_B, slip, state) and the dissipated energy.
  h5::write_int_attribute(g, "summary_stick", m.stick);
  h5::write_int_attribute(g, "summary_slip", m.slip);
  h5::write_double_attribute(g, "summary_tangential_force", m.tangential_force);
  h5::write_double_attribute(g, "summary_dissipation", m.dissipation);
  h5::write_double_attribute(g, "friction_dissipated", c.dissipated);
  std::vector<int> keys;
  std::vector<double> values;
  for (const auto& w : c.committed) {
    keys.insert(keys.end(), w.key.begin(), w.key.end());
    values.insert(values.end(), {w.zeta_A, w.theta_A, w.zeta_B, w.theta_B, w.active ? 1.0 : 0.0});
  }
  write_table(g, "committed_keys", keys, 3);
  write_table(g, "committed", values, 5);
  values.clear();
  for (const auto& w : c.committed)
    values.insert(values.end(), {w.anchor_zeta_A, w.anchor_theta_A, w.anchor_zeta_B,
                                 w.anchor_theta_B, w.slip, static_cast<double>(w.friction)});
  write_table(g, "committed_friction", values, 6);
  // Torsional friction (twist_anchor, twist_slip, twist state) and the summary's figures of it:
  // written by versions with surface torsional friction; an older checkpoint has none.
  write_committed_twist(g, c.committed);
  h5::write_int_attribute(g, "summary_twist_stick", m.twist_stick);
  h5::write_int_attribute(g, "summary_twist_slip", m.twist_slip);
  h5::write_double_attribute(g, "summary_torque", m.torque);
  keys.clear();
  values.clear();
  std::vector<int> flags;
  for (const auto& p : c.pairs) {
    keys.insert(keys.end(), p.key.begin(), p.key.end());
    flags.insert(flags.end(), {static_cast<int>(p.status), static_cast<int>(p.degeneration),
                               p.active ? 1 : 0, p.iterations});
    values.insert(values.end(), {p.zeta_A, p.theta_A, p.zeta_B, p.theta_B, p.gap, p.penetration,
                                 p.penetration_rate, p.force, p.potential, p.share, p.share_A,
                                 p.share_B, p.factor});
    for (const Eigen::Vector3d* v : {&p.point_A, &p.point_B, &p.normal})
      values.insert(values.end(), {v->x(), v->y(), v->z()});
  }
  write_table(g, "pair_keys", keys, 3);
  write_table(g, "pair_flags", flags, 4);
  write_table(g, "pair_values", values, kSurfacePairValues);
}

void write_explicit(hid_t parent, const ExplicitProgress& p) {
  h5::Handle group = h5::create_group(parent, "explicit");
  const hid_t g = group.id();
  h5::write_int_attribute(g, "step", p.step);
  h5::write_double_attribute(g, "time", p.time);
  h5::write_double_attribute(g, "count", static_cast<double>(p.count));
  h5::write_double_attribute(g, "h_target", p.h_target);
  h5::write_double_attribute(g, "dt_min", p.dt_min);
  h5::write_double_attribute(g, "supplied_start", p.supplied_start);
  h5::write_double_attribute(g, "supplied_max", p.supplied_max);
  h5::write_double_attribute(g, "prescribed_start", p.prescribed_start);
  h5::write_double_attribute(g, "energy_floor", p.energy_floor);
  h5::write_double_attribute(g, "kick_work", p.kick_work);
  write_status(g, "status_", p.status);
  h5::write_dataset(g, "scale", std::span<const double>(p.scale),
                    std::array<hsize_t, 1>{p.scale.size()});
  write_columns<3>(g, "force", p.force);
  write_columns<3>(g, "moment", p.moment);
  write_columns<6>(g, "loads", p.loads);
  write_columns<3>(g, "v_half", p.v_half);
  write_columns<3>(g, "omega_half", p.omega_half);
  write_columns<3>(g, "pi", p.pi);
}

// ---- reading -------------------------------------------------------------------------------

/// Reads dataset name of shape (rows, columns); rows < 0: any.
std::vector<double> read_table(hid_t group, const std::string& name, long rows,
                               std::size_t columns) {
  std::vector<hsize_t> dims;
  std::vector<double> v = h5::read_doubles(group, name, &dims);
  if (dims.size() != 2 || dims[1] != columns || (rows >= 0 && dims[0] != hsize_t(rows)))
    throw RestartError(fmt::format("checkpoint: dataset {} has shape ({}), expected ({}, {})", name,
                                   fmt::join(dims, ", "), rows >= 0 ? std::to_string(rows) : "n",
                                   columns));
  return v;
}

/// Reads write_committed_twist's table into `committed` (already sized), checking the states;
/// `what` names the contact in the error ("contact", "surface contact").
template <class Committed>
void read_committed_twist(hid_t group, std::vector<Committed>& committed, const char* what) {
  const std::vector<double> twist =
      read_table(group, "committed_twist", static_cast<long>(committed.size()), 3);
  for (std::size_t i = 0; i < committed.size(); ++i) {
    Committed& w = committed[i];
    w.twist_anchor = twist[3 * i];
    w.twist_slip = twist[3 * i + 1];
    w.twist = static_cast<int>(twist[3 * i + 2]);
    if (w.twist < 0 || w.twist > 2)
      throw RestartError(
          fmt::format("checkpoint: committed {} {} has twist state {}", what, i, w.twist));
  }
}

std::vector<int> read_int_table(hid_t group, const std::string& name, std::size_t columns) {
  std::vector<hsize_t> dims;
  std::vector<int> v = h5::read_ints(group, name, &dims);
  if (dims.size() != 2 || dims[1] != columns)
    throw RestartError(fmt::format("checkpoint: dataset {} has shape ({}), expected (n, {})", name,
                                   fmt::join(dims, ", "), columns));
  return v;
}

template <int Rows>
Eigen::Matrix<double, Rows, Eigen::Dynamic> read_columns(hid_t group, const std::string& name,
                                                         long n) {
  const std::vector<double> v = read_table(group, name, n, Rows);
  Eigen::Matrix<double, Rows, Eigen::Dynamic> m(Rows, n);
  if (!v.empty())
    std::memcpy(m.data(), v.data(), v.size() * sizeof(double));
  return m;
}

ExplicitStatus read_status(hid_t object, const std::string& prefix) {
  ExplicitStatus s;
  s.critical_dt = h5::read_double_attribute(object, prefix + "critical_dt");
  s.stable_dt = h5::read_double_attribute(object, prefix + "stable_dt");
  s.limited_by = h5::read_string_attribute(object, prefix + "limited_by");
  s.dt = h5::read_double_attribute(object, prefix + "dt");
  s.added_mass = h5::read_double_attribute(object, prefix + "added_mass");
  s.added_mass_percent = h5::read_double_attribute(object, prefix + "added_mass_percent");
  s.added_rotary_percent = h5::read_double_attribute(object, prefix + "added_rotary_percent");
  s.increments = static_cast<long>(h5::read_double_attribute(object, prefix + "increments"));
  return s;
}

/// As write_search_boxes wrote them.
std::vector<std::vector<Eigen::AlignedBox3d>> read_search_boxes(hid_t g) {
  std::vector<std::vector<Eigen::AlignedBox3d>> out;
  const int definitions = h5::read_int_attribute(g, "definitions");
  for (int k = 0; k < definitions; ++k) {
    const std::vector<double> v = read_table(g, fmt::format("boxes_{}", k), -1, 6);
    std::vector<Eigen::AlignedBox3d> boxes;
    for (std::size_t i = 0; i < v.size(); i += 6)
      boxes.emplace_back(Eigen::Vector3d(v[i], v[i + 1], v[i + 2]),
                         Eigen::Vector3d(v[i + 3], v[i + 4], v[i + 5]));
    out.push_back(std::move(boxes));
  }
  return out;
}

SplineContactSet::Snapshot read_contact(hid_t parent) {
  h5::Handle group = h5::open_group(parent, "contact");
  const hid_t g = group.id();
  SplineContactSet::Snapshot c;
  c.candidates_version = h5::read_int_attribute(g, "candidates_version");
  c.search_boxes = read_search_boxes(g);
  std::vector<int> keys = read_int_table(g, "committed_keys", 3);
  std::vector<double> values = read_table(g, "committed", static_cast<long>(keys.size() / 3), 3);
  for (std::size_t i = 0; i < keys.size() / 3; ++i)
    c.committed.push_back({{keys[3 * i], keys[3 * i + 1], keys[3 * i + 2]},
                           values[3 * i],
                           values[3 * i + 1],
                           values[3 * i + 2] != 0.0});
  if (h5::exists(g, "committed_friction")) {
    const std::vector<double> friction =
        read_table(g, "committed_friction", static_cast<long>(c.committed.size()), 4);
    for (std::size_t i = 0; i < c.committed.size(); ++i) {
      auto& w = c.committed[i];
      w.anchor_A = friction[4 * i];
      w.anchor_B = friction[4 * i + 1];
      w.slip = friction[4 * i + 2];
      w.friction = static_cast<int>(friction[4 * i + 3]);
      if (w.friction < 0 || w.friction > 2)
        throw RestartError(
            fmt::format("checkpoint: committed contact {} has friction state {}", i, w.friction));
    }
    c.dissipated = h5::read_double_attribute(g, "friction_dissipated");
  }
  if (h5::exists(g, "committed_twist"))
    read_committed_twist(g, c.committed, "contact");
  if (h5::exists(g, "line_committed_keys")) {
    const std::vector<int> line_keys = read_int_table(g, "line_committed_keys", 4);
    const long lines = static_cast<long>(line_keys.size() / 4);
    const std::vector<double> line = read_table(g, "line_committed", lines, 3);
    for (long i = 0; i < lines; ++i) {
      const int* k = &line_keys[4 * i];
      const SplineContactSet::Snapshot::LineWarm w{{k[0], k[1], k[2], k[3]},
                                                   line[3 * i],
                                                   line[3 * i + 1],
                                                   static_cast<int>(line[3 * i + 2])};
      if (w.friction < 1 || w.friction > 2)
        throw RestartError(fmt::format(
            "checkpoint: committed line contact point {} has friction state {}", i, w.friction));
      if (i > 0 && !(c.line_committed.back().key < w.key))
        throw RestartError(fmt::format(
            "checkpoint: committed line contact points are not in ascending order at {}", i));
      c.line_committed.push_back(w);
    }
  }
  keys = read_int_table(g, "pair_keys", 3);
  const long n = static_cast<long>(keys.size() / 3);
  const std::vector<int> flags = read_int_table(g, "pair_flags", 4);
  values = read_table(g, "pair_values", n, 17);
  if (static_cast<long>(flags.size() / 4) != n)
    throw RestartError("checkpoint: contact pair_flags and pair_keys differ in length");
  for (long i = 0; i < n; ++i) {
    const double* v = &values[17 * i];
    const int* f = &flags[4 * i];
    if (f[0] < 0 || f[0] > static_cast<int>(contact::ProjectionStatus::Jumped))
      throw RestartError(fmt::format("checkpoint: contact pair {} has status {}", i, f[0]));
    c.pairs.push_back({{keys[3 * i], keys[3 * i + 1], keys[3 * i + 2]},
                       static_cast<contact::ProjectionStatus>(f[0]),
                       f[1] != 0,
                       f[2] != 0,
                       f[3],
                       v[0],
                       v[1],
                       v[2],
                       v[3],
                       v[4],
                       v[5],
                       v[6],
                       v[7],
                       Eigen::Vector3d(v[8], v[9], v[10]),
                       Eigen::Vector3d(v[11], v[12], v[13]),
                       Eigen::Vector3d(v[14], v[15], v[16])});
  }
  return c;
}

SurfaceContactSet::Snapshot read_surface_contact(hid_t parent) {
  h5::Handle group = h5::open_group(parent, "surface_contact");
  const hid_t g = group.id();
  SurfaceContactSet::Snapshot c;
  c.candidates_version = h5::read_int_attribute(g, "candidates_version");
  c.search_boxes = read_search_boxes(g);
  ContactSummary& m = c.summary;
  m.candidates = h5::read_int_attribute(g, "summary_candidates");
  m.active = h5::read_int_attribute(g, "summary_active");
  // Written since the active pairs' shares are summed over processes (ContactSummary); the
  // rounded count before.
  const std::vector<std::string> names = h5::attribute_names(g);
  m.active_share = std::find(names.begin(), names.end(), "summary_active_share") != names.end()
                       ? h5::read_double_attribute(g, "summary_active_share")
                       : m.active;
  m.max_penetration = h5::read_double_attribute(g, "summary_max_penetration");
  m.max_force = h5::read_double_attribute(g, "summary_max_force");
  m.potential = h5::read_double_attribute(g, "summary_potential");
  m.total_force = h5::read_double_attribute(g, "summary_total_force");
  m.min_gap = h5::read_double_attribute(g, "summary_min_gap");
  std::vector<int> keys = read_int_table(g, "committed_keys", 3);
  std::vector<double> values = read_table(g, "committed", static_cast<long>(keys.size() / 3), 5);
  for (std::size_t i = 0; i < keys.size() / 3; ++i) {
    const double* v = &values[5 * i];
    c.committed.push_back(
        {{keys[3 * i], keys[3 * i + 1], keys[3 * i + 2]}, v[0], v[1], v[2], v[3], v[4] != 0.0});
  }
  if (h5::exists(g, "committed_friction")) {
    m.stick = h5::read_int_attribute(g, "summary_stick");
    m.slip = h5::read_int_attribute(g, "summary_slip");
    m.tangential_force = h5::read_double_attribute(g, "summary_tangential_force");
    m.dissipation = h5::read_double_attribute(g, "summary_dissipation");
    c.dissipated = h5::read_double_attribute(g, "friction_dissipated");
    const std::vector<double> friction =
        read_table(g, "committed_friction", static_cast<long>(c.committed.size()), 6);
    for (std::size_t i = 0; i < c.committed.size(); ++i) {
      auto& w = c.committed[i];
      const double* f = &friction[6 * i];
      w.anchor_zeta_A = f[0];
      w.anchor_theta_A = f[1];
      w.anchor_zeta_B = f[2];
      w.anchor_theta_B = f[3];
      w.slip = f[4];
      w.friction = static_cast<int>(f[5]);
      if (w.friction < 0 || w.friction > 2)
        throw RestartError(fmt::format(
            "checkpoint: committed surface contact {} has friction state {}", i, w.friction));
    }
  }
  if (h5::exists(g, "committed_twist")) {
    m.twist_stick = h5::read_int_attribute(g, "summary_twist_stick");
    m.twist_slip = h5::read_int_attribute(g, "summary_twist_slip");
    m.torque = h5::read_double_attribute(g, "summary_torque");
    read_committed_twist(g, c.committed, "surface contact");
  }
  keys = read_int_table(g, "pair_keys", 3);
  const long n = static_cast<long>(keys.size() / 3);
  const std::vector<int> flags = read_int_table(g, "pair_flags", 4);
  values = read_table(g, "pair_values", n, kSurfacePairValues);
  if (static_cast<long>(flags.size() / 4) != n)
    throw RestartError("checkpoint: surface contact pair_flags and pair_keys differ in length");
  for (long i = 0; i < n; ++i) {
    const double* v = &values[kSurfacePairValues * i];
    const int* f = &flags[4 * i];
    if (f[0] < 0 || f[0] > static_cast<int>(contact::ProjectionStatus::Jumped))
      throw RestartError(fmt::format("checkpoint: surface contact pair {} has status {}", i, f[0]));
    if (f[1] < 0 || f[1] > static_cast<int>(contact::SurfaceDegeneration::RidgeOnBoth))
      throw RestartError(
          fmt::format("checkpoint: surface contact pair {} has degeneration {}", i, f[1]));
    c.pairs.push_back({{keys[3 * i], keys[3 * i + 1], keys[3 * i + 2]},
                       static_cast<contact::ProjectionStatus>(f[0]),
                       static_cast<contact::SurfaceDegeneration>(f[1]),
                       f[2] != 0,
                       f[3],
                       v[0],
                       v[1],
                       v[2],
                       v[3],
                       v[4],
                       v[5],
                       v[6],
                       v[7],
                       v[8],
                       v[9],
                       v[10],
                       v[11],
                       v[12],
                       Eigen::Vector3d(v[13], v[14], v[15]),
                       Eigen::Vector3d(v[16], v[17], v[18]),
                       Eigen::Vector3d(v[19], v[20], v[21])});
  }
  return c;
}

ExplicitProgress read_explicit(hid_t parent, long n_nodes) {
  h5::Handle group = h5::open_group(parent, "explicit");
  const hid_t g = group.id();
  ExplicitProgress p;
  p.step = h5::read_int_attribute(g, "step");
  p.time = h5::read_double_attribute(g, "time");
  p.count = static_cast<long>(h5::read_double_attribute(g, "count"));
  p.h_target = h5::read_double_attribute(g, "h_target");
  p.dt_min = h5::read_double_attribute(g, "dt_min");
  p.supplied_start = h5::read_double_attribute(g, "supplied_start");
  p.supplied_max = h5::read_double_attribute(g, "supplied_max");
  p.prescribed_start = h5::read_double_attribute(g, "prescribed_start");
  p.energy_floor = h5::read_double_attribute(g, "energy_floor");
  p.kick_work = h5::read_double_attribute(g, "kick_work");
  p.status = read_status(g, "status_");
  p.scale = h5::read_doubles(g, "scale");
  p.force = read_columns<3>(g, "force", n_nodes);
  p.moment = read_columns<3>(g, "moment", n_nodes);
  p.loads = read_columns<6>(g, "loads", n_nodes);
  p.v_half = read_columns<3>(g, "v_half", n_nodes);
  p.omega_half = read_columns<3>(g, "omega_half", n_nodes);
  p.pi = read_columns<3>(g, "pi", n_nodes);
  return p;
}

} // namespace

std::string deck_fingerprint(std::string_view deck_text, const Model& model) {
  Fnv1a f;
  f.add(deck_text.data(), deck_text.size());
  for (const Eigen::Vector3d& x : model.nodes)
    f.add(x.data(), 3 * sizeof(double));
  for (const BeamElement& e : model.elements)
    f.add(e.nodes.data(), sizeof(e.nodes));
  return fmt::format("{:016x}", f.h);
}

void write_checkpoint(const std::filesystem::path& dir, const SimulationCheckpoint& c,
                      const CheckpointOutputs& outputs) {
  const std::filesystem::path path = dir / kCheckpointName;
  std::filesystem::path tmp = path;
  tmp += ".tmp";
  {
    h5::Handle file = h5::create_file(tmp);
    const hid_t root = file.id();
    const State& s = c.state;
    h5::write_string_attribute(root, "format", kFormat);
    h5::write_string_attribute(root, "version", kVersion);
    h5::write_string_attribute(root, "deck_hash", outputs.deck_hash);
    h5::write_int_attribute(root, "increment", s.increment);
    h5::write_double_attribute(root, "time", s.time);
    h5::write_int_attribute(root, "step", c.step);
    h5::write_double_attribute(root, "next_dt", c.next_dt);
    h5::write_int_attribute(root, "results_steps", outputs.results_steps);
    h5::write_double_attribute(root, "external_work", c.external_work);
    h5::write_double_attribute(root, "prescribed_work", c.prescribed_work);
    h5::write_double_attribute(root, "damping_work", c.damping_work);
    h5::write_double_attribute(root, "energy_reference", c.energy_reference);
    h5::write_int_attribute(root, "total_iterations", c.total_iterations);
    h5::write_int_attribute(root, "simplified_trials", c.simplified_trials);
    write_status(root, "explicit_", c.explicit_status);
    if (!c.partition_cuts.empty())
      write_table(root, "partition_cuts", c.partition_cuts, 1);

    h5::Handle out = h5::create_group(root, "outputs");
    for (const auto& [name, rows] : outputs.csv_rows)
      h5::write_int_attribute(out.id(), name, static_cast<int>(rows));
    out.close();

    h5::Handle state = h5::create_group(root, "state");
    const hid_t g = state.id();
    write_columns<3>(g, "x_n", s.x_n);
    write_columns<3>(g, "v_n", s.v_n);
    write_columns<3>(g, "a_n", s.a_n);
    write_columns<3>(g, "W_n", s.W_n);
    write_columns<3>(g, "A_n", s.A_n);
    write_columns<3>(g, "rotation_n", s.rotation_n);
    std::vector<double> Q, gauss_Q, gauss_kappa;
    Q.reserve(9 * s.Q_n.size());
    for (const Eigen::Matrix3d& R : s.Q_n)
      Q.insert(Q.end(), R.data(), R.data() + 9);
    for (const auto& element : s.gauss)
      for (const GaussState& gp : element) {
        gauss_Q.insert(gauss_Q.end(), gp.Q_n.data(), gp.Q_n.data() + 9);
        gauss_kappa.insert(gauss_kappa.end(), gp.kappa_n.data(), gp.kappa_n.data() + 3);
      }
    write_table(g, "Q_n", Q, 9);
    write_table(g, "gauss_Q", gauss_Q, 9);
    write_table(g, "gauss_kappa", gauss_kappa, 3);
    write_columns<6>(g, "reactions", c.reactions);
    write_columns<6>(g, "load_n", c.load_n);
    // The secant predictor's last increment, where a step has used it.
    if (c.secant_step >= 0) {
      write_columns<3>(g, "secant_motion", c.secant_motion);
      write_columns<3>(g, "secant_rotation", c.secant_rotation);
      h5::write_double_attribute(g, "secant_dt", c.secant_dt);
      h5::write_int_attribute(g, "secant_step", c.secant_step);
      h5::write_double_attribute(g, "secant_reach", c.secant_reach);
    }
    state.close();

    h5::Handle pattern = h5::create_group(root, "pattern");
    std::vector<int> groups;
    // Per coupling: its 6 nodes, then 1 if it couples rotations, else 0.
    for (const auto& group : c.pattern_groups) {
      groups.insert(groups.end(), group.nodes.begin(), group.nodes.end());
      groups.push_back(group.rotations ? 1 : 0);
    }
    write_table(pattern.id(), "groups", groups, 7);
    if (!c.ordering.inverse_permutation.empty()) {
      write_table(pattern.id(), "ordering", c.ordering.inverse_permutation, 1);
      h5::write_double_attribute(pattern.id(), "ordering_fill", c.ordering.fill);
    }
    pattern.close();

    if (c.contact)
      write_contact(root, *c.contact);
    if (c.surface_contact)
      write_surface_contact(root, *c.surface_contact);
    if (c.explicit_progress)
      write_explicit(root, *c.explicit_progress);
    file.close();
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec)
    throw std::runtime_error(fmt::format("checkpoint: cannot rename {} to {}: {}", tmp.string(),
                                         path.string(), ec.message()));
}

StoredCheckpoint read_checkpoint(const std::filesystem::path& dir) {
  const std::filesystem::path path = dir / kCheckpointName;
  if (!std::filesystem::exists(path))
    throw RestartError(
        fmt::format("cannot restart from {}: it holds no {} (a run writes one after each completed "
                    "increment; was it run by this version, and did it complete an increment?)",
                    dir.string(), kCheckpointName));
  h5::Handle file = h5::open_file_read_only(path);
  const hid_t root = file.id();
  std::string format;
  try {
    format = h5::read_string_attribute(root, "format");
  } catch (const std::runtime_error&) {
  }
  if (format != kFormat)
    throw RestartError(fmt::format("cannot restart from {}: {} is not a checkpoint of format '{}'",
                                   dir.string(), path.string(), kFormat));
  StoredCheckpoint out;
  CheckpointOutputs& o = out.outputs;
  SimulationCheckpoint& c = out.simulation;
  o.deck_hash = h5::read_string_attribute(root, "deck_hash");
  o.results_steps = h5::read_int_attribute(root, "results_steps");
  {
    h5::Handle group = h5::open_group(root, "outputs");
    for (const std::string& name : h5::attribute_names(group.id()))
      o.csv_rows[name] = h5::read_int_attribute(group.id(), name);
  }
  State& s = c.state;
  s.increment = h5::read_int_attribute(root, "increment");
  s.time = h5::read_double_attribute(root, "time");
  c.step = h5::read_int_attribute(root, "step");
  c.next_dt = h5::read_double_attribute(root, "next_dt");
  c.external_work = h5::read_double_attribute(root, "external_work");
  c.prescribed_work = h5::read_double_attribute(root, "prescribed_work");
  c.damping_work = h5::read_double_attribute(root, "damping_work");
  c.energy_reference = h5::read_double_attribute(root, "energy_reference");
  c.total_iterations = h5::read_int_attribute(root, "total_iterations");
  // Written since 2026-12-07 (absent: none counted).
  if (h5::attribute_exists(root, "simplified_trials"))
    c.simplified_trials = h5::read_int_attribute(root, "simplified_trials");
  c.explicit_status = read_status(root, "explicit_");
  // Written over several processes since the partition is balanced (absent: none).
  if (h5::exists(root, "partition_cuts"))
    c.partition_cuts = h5::read_ints(root, "partition_cuts");

  h5::Handle state = h5::open_group(root, "state");
  const hid_t g = state.id();
  std::vector<hsize_t> dims;
  h5::read_doubles(g, "x_n", &dims);
  const long n = dims.empty() ? 0 : static_cast<long>(dims[0]);
  s.x_n = read_columns<3>(g, "x_n", n);
  s.v_n = read_columns<3>(g, "v_n", n);
  s.a_n = read_columns<3>(g, "a_n", n);
  s.W_n = read_columns<3>(g, "W_n", n);
  s.A_n = read_columns<3>(g, "A_n", n);
  s.rotation_n = read_columns<3>(g, "rotation_n", n);
  const std::vector<double> Q = read_table(g, "Q_n", n, 9);
  s.Q_n.resize(n);
  for (long i = 0; i < n; ++i)
    s.Q_n[i] = Eigen::Map<const Eigen::Matrix3d>(&Q[9 * i]);
  const std::vector<double> gauss_Q = read_table(g, "gauss_Q", -1, 9);
  const long n_gauss = static_cast<long>(gauss_Q.size() / 9);
  if (n_gauss % 2 != 0)
    throw RestartError(
        fmt::format("checkpoint: {} Gauss points, expected two per element", n_gauss));
  const std::vector<double> gauss_kappa = read_table(g, "gauss_kappa", n_gauss, 3);
  s.gauss.resize(n_gauss / 2);
  for (long k = 0; k < n_gauss; ++k)
    s.gauss[k / 2][k % 2] = GaussState{Eigen::Map<const Eigen::Matrix3d>(&gauss_Q[9 * k]),
                                       Eigen::Map<const Eigen::Vector3d>(&gauss_kappa[3 * k])};
  c.reactions = read_columns<6>(g, "reactions", n);
  c.load_n = read_columns<6>(g, "load_n", n);
  // Written by versions with the secant predictor, where a step used it.
  if (h5::exists(g, "secant_motion")) {
    c.secant_motion = read_columns<3>(g, "secant_motion", n);
    // Written since the secant carries rotations (absent: the translations alone).
    c.secant_rotation = h5::exists(g, "secant_rotation") ? read_columns<3>(g, "secant_rotation", n)
                                                         : Eigen::Matrix3Xd::Zero(3, n);
    c.secant_dt = h5::read_double_attribute(g, "secant_dt");
    c.secant_step = h5::read_int_attribute(g, "secant_step");
    // Written since frictional tension tests choose the secant (absent: not held).
    if (h5::attribute_exists(g, "secant_reach"))
      c.secant_reach = h5::read_double_attribute(g, "secant_reach");
  }
  s.x = s.x_n;
  s.alpha = Eigen::Matrix3Xd::Zero(3, n);

  h5::Handle pattern = h5::open_group(root, "pattern");
  const std::vector<int> groups = read_int_table(pattern.id(), "groups", 7);
  for (std::size_t i = 0; i < groups.size(); i += 7)
    c.pattern_groups.push_back(
        {{groups[i], groups[i + 1], groups[i + 2], groups[i + 3], groups[i + 4], groups[i + 5]},
         groups[i + 6] != 0});
  if (h5::exists(pattern.id(), "ordering")) {
    c.ordering.inverse_permutation = read_int_table(pattern.id(), "ordering", 1);
    c.ordering.fill = h5::read_double_attribute(pattern.id(), "ordering_fill");
  }

  if (h5::exists(root, "contact"))
    c.contact = read_contact(root);
  if (h5::exists(root, "surface_contact"))
    c.surface_contact = read_surface_contact(root);
  if (h5::exists(root, "explicit"))
    c.explicit_progress = read_explicit(root, n);
  return out;
}

} // namespace yarnsim::output
