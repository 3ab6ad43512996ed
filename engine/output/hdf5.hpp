#pragma once
// A small RAII layer over the HDF5 1.10 C API: owned identifiers and the few writes the results
// file needs. Every call that returns a negative id or status throws std::runtime_error naming the
// call, the object (file and path inside it) and HDF5's own description of the error.

#include <hdf5.h>

#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace yarnsim::output::h5 {

/// Throws std::runtime_error "HDF5: <what> failed: <innermost HDF5 error>" when status < 0;
/// returns status otherwise.
herr_t check(herr_t status, std::string_view what);
/// Same for a returned identifier: throws when id < 0, returns id otherwise.
hid_t check_id(hid_t id, std::string_view what);

/// An owned HDF5 identifier, released with the H5*close function that matches its kind.
class Handle {
public:
  using Closer = herr_t (*)(hid_t);

  Handle() = default;
  /// Takes ownership of id; throws (via check_id) when id < 0, naming what.
  Handle(hid_t id, Closer closer, std::string_view what);
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& other) noexcept;
  Handle& operator=(Handle&& other) noexcept;
  /// Releases the id; never throws (a failure is ignored).
  ~Handle();

  hid_t id() const { return id_; }
  bool valid() const { return id_ >= 0; }
  /// Releases the id now and throws if HDF5 reports a failure (e.g. a file that cannot be
  /// flushed on close).
  void close();

private:
  hid_t id_ = H5I_INVALID_HID;
  Closer closer_ = nullptr;
};

/// "<file>:<path>" of an open object, for error messages; "<unnamed>" if HDF5 cannot tell.
std::string describe(hid_t object);

/// Creates (truncating) an HDF5 file with file locking disabled, so that a reader such as ParaView
/// can open it while this process writes, and with the 1.8 object format so that attributes may
/// exceed 64 KiB (the deck text).
Handle create_file(const std::filesystem::path& file);
/// Opens an existing file read-only, file locking disabled.
Handle open_file_read_only(const std::filesystem::path& file);
/// Opens an existing file for reading and writing, file locking disabled.
Handle open_file_read_write(const std::filesystem::path& file);
/// Flushes every buffer of the file holding object to the operating system.
void flush(hid_t object);

/// Creates group name (relative to parent, intermediate groups created as needed). With
/// attribute_order, the group tracks the creation order of its attributes (attribute_names).
Handle create_group(hid_t parent, const std::string& name, bool attribute_order = false);
/// Opens an existing group.
Handle open_group(hid_t parent, const std::string& name);
/// Whether parent has a link called name (one path component).
bool exists(hid_t parent, const std::string& name);
/// Whether object has an attribute called name.
bool attribute_exists(hid_t object, const std::string& name);
/// Removes the link name under parent.
void remove(hid_t parent, const std::string& name);
/// Names of the links directly under a group, in name order.
std::vector<std::string> link_names(hid_t group);
/// Names of a group's attributes: in creation order when the group tracks it, in name order
/// otherwise.
std::vector<std::string> attribute_names(hid_t group);

/// Creates dataset name under parent with shape dims (row-major, the last dimension varies
/// fastest) and writes data into it; data.size() must equal the product of dims. A dimension may
/// be zero (an empty dataset).
void write_dataset(hid_t parent, const std::string& name, std::span<const double> data,
                   std::span<const hsize_t> dims);
void write_dataset(hid_t parent, const std::string& name, std::span<const int> data,
                   std::span<const hsize_t> dims);
/// As float32 (points for drawing).
void write_dataset(hid_t parent, const std::string& name, std::span<const float> data,
                   std::span<const hsize_t> dims);

/// Writes (or replaces) a scalar attribute on object: a variable-length UTF-8 string, a 32-bit
/// integer or a double.
void write_string_attribute(hid_t object, const std::string& name, std::string_view value);
void write_int_attribute(hid_t object, const std::string& name, int value);
void write_double_attribute(hid_t object, const std::string& name, double value);

/// Reads dataset name under parent, converted to double or int; dims (if given) receives its
/// shape. Throws std::runtime_error when it is missing or cannot be read.
std::vector<double> read_doubles(hid_t parent, const std::string& name,
                                 std::vector<hsize_t>* dims = nullptr);
std::vector<int> read_ints(hid_t parent, const std::string& name,
                           std::vector<hsize_t>* dims = nullptr);
/// Reads a scalar attribute written by the functions above.
std::string read_string_attribute(hid_t object, const std::string& name);
int read_int_attribute(hid_t object, const std::string& name);
double read_double_attribute(hid_t object, const std::string& name);

} // namespace yarnsim::output::h5
