#include "engine/output/hdf5.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <stdexcept>
#include <utility>
#include <vector>

namespace yarnsim::output::h5 {
namespace {

/// HDF5's description of the error just reported: the failing API call and, if different, the
/// innermost cause (e.g. "unable to lock file, errno = 11"). Must run before any other HDF5 call,
/// since API calls clear the error stack.
std::string error_stack_summary() {
  std::vector<std::string> entries;
  auto collect = [](unsigned, const H5E_error2_t* e, void* out) -> herr_t {
    static_cast<std::vector<std::string>*>(out)->push_back(
        fmt::format("{}(): {}", e->func_name ? e->func_name : "?", e->desc ? e->desc : ""));
    return 0;
  };
  if (H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, collect, &entries) < 0 || entries.empty())
    return "no HDF5 error description";
  if (entries.size() == 1)
    return entries.front();
  return fmt::format("{} (innermost: {})", entries.front(), entries.back());
}

/// Throws when value < 0, naming the call, the object name and where it is (parent object).
template <class T>
T checked(T value, std::string_view call, hid_t parent, std::string_view name) {
  if (value >= 0)
    return value;
  const std::string cause = error_stack_summary();
  throw std::runtime_error(
      fmt::format("HDF5: {} failed for '{}' under {}: {}", call, name, describe(parent), cause));
}

hsize_t element_count(std::span<const hsize_t> dims) {
  hsize_t n = 1;
  for (hsize_t d : dims)
    n *= d;
  return n;
}

void write_dataset_impl(hid_t parent, const std::string& name, const void* data, std::size_t size,
                        hid_t memory_type, hid_t file_type, std::span<const hsize_t> dims) {
  if (dims.empty())
    throw std::invalid_argument(
        fmt::format("HDF5: dataset '{}' needs at least one dimension", name));
  if (element_count(dims) != size)
    throw std::invalid_argument(
        fmt::format("HDF5: dataset '{}' of shape ({}) holds {} values, got {}", name,
                    fmt::join(dims, ", "), element_count(dims), size));
  Handle space(checked(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr),
                       "H5Screate_simple", parent, name),
               H5Sclose, "H5Screate_simple");
  Handle dataset(checked(H5Dcreate2(parent, name.c_str(), file_type, space.id(), H5P_DEFAULT,
                                    H5P_DEFAULT, H5P_DEFAULT),
                         "H5Dcreate2", parent, name),
                 H5Dclose, "H5Dcreate2");
  // An empty dataset has nothing to write (and H5Dwrite rejects a null buffer).
  if (size > 0)
    checked(H5Dwrite(dataset.id(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), "H5Dwrite",
            parent, name);
  dataset.close();
}

/// Creates a scalar attribute of the given type, replacing one of the same name.
Handle create_scalar_attribute(hid_t object, const std::string& name, hid_t file_type) {
  const htri_t exists = checked(H5Aexists(object, name.c_str()), "H5Aexists", object, name);
  if (exists > 0)
    checked(H5Adelete(object, name.c_str()), "H5Adelete", object, name);
  Handle space(checked(H5Screate(H5S_SCALAR), "H5Screate", object, name), H5Sclose, "H5Screate");
  return Handle(
      checked(H5Acreate2(object, name.c_str(), file_type, space.id(), H5P_DEFAULT, H5P_DEFAULT),
              "H5Acreate2", object, name),
      H5Aclose, "H5Acreate2");
}

Handle file_access_without_locking() {
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "H5Pcreate(H5P_FILE_ACCESS)");
#if H5_VERSION_GE(1, 10, 7)
  // HDF5 1.10 locks a file for its whole lifetime; ParaView could not open the results while the
  // run writes. Steps are flushed whole, so a reader sees every completed step.
  check(H5Pset_file_locking(fapl.id(), false, true), "H5Pset_file_locking");
#else
#warning "HDF5 < 1.10.7: no H5Pset_file_locking; set HDF5_USE_FILE_LOCKING=FALSE to read live files"
#endif
  return fapl;
}

} // namespace

herr_t check(herr_t status, std::string_view what) {
  if (status < 0)
    throw std::runtime_error(fmt::format("HDF5: {} failed: {}", what, error_stack_summary()));
  return status;
}

hid_t check_id(hid_t id, std::string_view what) {
  if (id < 0)
    throw std::runtime_error(fmt::format("HDF5: {} failed: {}", what, error_stack_summary()));
  return id;
}

Handle::Handle(hid_t id, Closer closer, std::string_view what)
    : id_(check_id(id, what)), closer_(closer) {}

Handle::Handle(Handle&& other) noexcept
    : id_(std::exchange(other.id_, H5I_INVALID_HID)), closer_(other.closer_) {}

Handle& Handle::operator=(Handle&& other) noexcept {
  if (this != &other) {
    if (valid())
      closer_(id_);
    id_ = std::exchange(other.id_, H5I_INVALID_HID);
    closer_ = other.closer_;
  }
  return *this;
}

Handle::~Handle() {
  if (valid())
    closer_(id_);
}

void Handle::close() {
  if (!valid())
    return;
  const hid_t id = std::exchange(id_, H5I_INVALID_HID);
  check(closer_(id), "closing an identifier");
}

std::string describe(hid_t object) {
  auto read_name = [](auto getter) -> std::string {
    const ssize_t n = getter(nullptr, 0);
    if (n < 0)
      return "<unnamed>";
    std::string s(static_cast<std::size_t>(n) + 1, '\0');
    getter(s.data(), s.size());
    s.resize(static_cast<std::size_t>(n));
    return s;
  };
  const std::string file =
      read_name([&](char* buf, std::size_t size) { return H5Fget_name(object, buf, size); });
  const std::string path =
      read_name([&](char* buf, std::size_t size) { return H5Iget_name(object, buf, size); });
  return fmt::format("{}:{}", file, path);
}

Handle create_file(const std::filesystem::path& file) {
  Handle fapl = file_access_without_locking();
  const hid_t id = H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.id());
  if (id < 0)
    throw std::runtime_error(
        fmt::format("HDF5: cannot create {}: {}", file.string(), error_stack_summary()));
  return Handle(id, H5Fclose, "H5Fcreate");
}

Handle open_file_read_only(const std::filesystem::path& file) {
  Handle fapl = file_access_without_locking();
  const hid_t id = H5Fopen(file.c_str(), H5F_ACC_RDONLY, fapl.id());
  if (id < 0)
    throw std::runtime_error(
        fmt::format("HDF5: cannot open {} read-only: {}", file.string(), error_stack_summary()));
  return Handle(id, H5Fclose, "H5Fopen");
}

Handle open_file_read_write(const std::filesystem::path& file) {
  Handle fapl = file_access_without_locking();
  const hid_t id = H5Fopen(file.c_str(), H5F_ACC_RDWR, fapl.id());
  if (id < 0)
    throw std::runtime_error(
        fmt::format("HDF5: cannot open {} for writing: {}", file.string(), error_stack_summary()));
  return Handle(id, H5Fclose, "H5Fopen");
}

void flush(hid_t object) {
  checked(H5Fflush(object, H5F_SCOPE_GLOBAL), "H5Fflush", object, "");
}

Handle create_group(hid_t parent, const std::string& name, bool attribute_order) {
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose, "H5Pcreate(H5P_LINK_CREATE)");
  check(H5Pset_create_intermediate_group(lcpl.id(), 1), "H5Pset_create_intermediate_group");
  Handle gcpl(H5Pcreate(H5P_GROUP_CREATE), H5Pclose, "H5Pcreate(H5P_GROUP_CREATE)");
  if (attribute_order)
    check(H5Pset_attr_creation_order(gcpl.id(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED),
          "H5Pset_attr_creation_order");
  return Handle(checked(H5Gcreate2(parent, name.c_str(), lcpl.id(), gcpl.id(), H5P_DEFAULT),
                        "H5Gcreate2", parent, name),
                H5Gclose, "H5Gcreate2");
}

Handle open_group(hid_t parent, const std::string& name) {
  return Handle(checked(H5Gopen2(parent, name.c_str(), H5P_DEFAULT), "H5Gopen2", parent, name),
                H5Gclose, "H5Gopen2");
}

bool exists(hid_t parent, const std::string& name) {
  return checked(H5Lexists(parent, name.c_str(), H5P_DEFAULT), "H5Lexists", parent, name) > 0;
}

bool attribute_exists(hid_t object, const std::string& name) {
  return checked(H5Aexists(object, name.c_str()), "H5Aexists", object, name) > 0;
}

void remove(hid_t parent, const std::string& name) {
  checked(H5Ldelete(parent, name.c_str(), H5P_DEFAULT), "H5Ldelete", parent, name);
}

std::vector<std::string> link_names(hid_t group) {
  std::vector<std::string> names;
  auto collect = [](hid_t, const char* name, const H5L_info_t*, void* out) -> herr_t {
    static_cast<std::vector<std::string>*>(out)->emplace_back(name);
    return 0;
  };
  checked(H5Literate(group, H5_INDEX_NAME, H5_ITER_INC, nullptr, collect, &names), "H5Literate",
          group, ".");
  return names;
}

std::vector<std::string> attribute_names(hid_t object) {
  Handle gcpl(H5Gget_create_plist(object), H5Pclose, "H5Gget_create_plist");
  unsigned flags = 0;
  check(H5Pget_attr_creation_order(gcpl.id(), &flags), "H5Pget_attr_creation_order");
  const H5_index_t index = (flags & H5P_CRT_ORDER_TRACKED) ? H5_INDEX_CRT_ORDER : H5_INDEX_NAME;
  std::vector<std::string> names;
  auto collect = [](hid_t, const char* name, const H5A_info_t*, void* out) -> herr_t {
    static_cast<std::vector<std::string>*>(out)->emplace_back(name);
    return 0;
  };
  checked(H5Aiterate2(object, index, H5_ITER_INC, nullptr, collect, &names), "H5Aiterate2", object,
          ".");
  return names;
}

void write_dataset(hid_t parent, const std::string& name, std::span<const double> data,
                   std::span<const hsize_t> dims) {
  write_dataset_impl(parent, name, data.data(), data.size(), H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE,
                     dims);
}

void write_dataset(hid_t parent, const std::string& name, std::span<const int> data,
                   std::span<const hsize_t> dims) {
  write_dataset_impl(parent, name, data.data(), data.size(), H5T_NATIVE_INT, H5T_STD_I32LE, dims);
}

void write_dataset(hid_t parent, const std::string& name, std::span<const float> data,
                   std::span<const hsize_t> dims) {
  write_dataset_impl(parent, name, data.data(), data.size(), H5T_NATIVE_FLOAT, H5T_IEEE_F32LE,
                     dims);
}

void write_string_attribute(hid_t object, const std::string& name, std::string_view value) {
  // Variable-length: the text lives in the global heap, so a long deck does not hit the 64 KiB
  // limit of compact attribute storage; h5py reads it as str.
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose, "H5Tcopy(H5T_C_S1)");
  check(H5Tset_size(type.id(), H5T_VARIABLE), "H5Tset_size(H5T_VARIABLE)");
  check(H5Tset_cset(type.id(), H5T_CSET_UTF8), "H5Tset_cset(H5T_CSET_UTF8)");
  Handle attribute = create_scalar_attribute(object, name, type.id());
  const std::string text(value);
  const char* pointer = text.c_str();
  checked(H5Awrite(attribute.id(), type.id(), &pointer), "H5Awrite", object, name);
  attribute.close();
}

void write_int_attribute(hid_t object, const std::string& name, int value) {
  Handle attribute = create_scalar_attribute(object, name, H5T_STD_I32LE);
  checked(H5Awrite(attribute.id(), H5T_NATIVE_INT, &value), "H5Awrite", object, name);
  attribute.close();
}

void write_double_attribute(hid_t object, const std::string& name, double value) {
  Handle attribute = create_scalar_attribute(object, name, H5T_IEEE_F64LE);
  checked(H5Awrite(attribute.id(), H5T_NATIVE_DOUBLE, &value), "H5Awrite", object, name);
  attribute.close();
}

namespace {

template <class T>
std::vector<T> read_dataset_impl(hid_t parent, const std::string& name, hid_t memory_type,
                                 std::vector<hsize_t>* dims_out) {
  Handle dataset(checked(H5Dopen2(parent, name.c_str(), H5P_DEFAULT), "H5Dopen2", parent, name),
                 H5Dclose, "H5Dopen2");
  Handle space(checked(H5Dget_space(dataset.id()), "H5Dget_space", parent, name), H5Sclose,
               "H5Dget_space");
  const int rank =
      checked(H5Sget_simple_extent_ndims(space.id()), "H5Sget_simple_extent_ndims", parent, name);
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  checked(H5Sget_simple_extent_dims(space.id(), dims.data(), nullptr), "H5Sget_simple_extent_dims",
          parent, name);
  std::vector<T> data(element_count(dims));
  if (!data.empty())
    checked(H5Dread(dataset.id(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()),
            "H5Dread", parent, name);
  if (dims_out)
    *dims_out = std::move(dims);
  return data;
}

Handle open_attribute(hid_t object, const std::string& name) {
  return Handle(checked(H5Aopen(object, name.c_str(), H5P_DEFAULT), "H5Aopen", object, name),
                H5Aclose, "H5Aopen");
}

} // namespace

std::vector<double> read_doubles(hid_t parent, const std::string& name,
                                 std::vector<hsize_t>* dims) {
  return read_dataset_impl<double>(parent, name, H5T_NATIVE_DOUBLE, dims);
}

std::vector<int> read_ints(hid_t parent, const std::string& name, std::vector<hsize_t>* dims) {
  return read_dataset_impl<int>(parent, name, H5T_NATIVE_INT, dims);
}

std::string read_string_attribute(hid_t object, const std::string& name) {
  Handle attribute = open_attribute(object, name);
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose, "H5Tcopy(H5T_C_S1)");
  check(H5Tset_size(type.id(), H5T_VARIABLE), "H5Tset_size(H5T_VARIABLE)");
  check(H5Tset_cset(type.id(), H5T_CSET_UTF8), "H5Tset_cset(H5T_CSET_UTF8)");
  char* pointer = nullptr;
  checked(H5Aread(attribute.id(), type.id(), &pointer), "H5Aread", object, name);
  std::string value = pointer ? pointer : "";
  H5free_memory(pointer);
  return value;
}

int read_int_attribute(hid_t object, const std::string& name) {
  Handle attribute = open_attribute(object, name);
  int value = 0;
  checked(H5Aread(attribute.id(), H5T_NATIVE_INT, &value), "H5Aread", object, name);
  return value;
}

double read_double_attribute(hid_t object, const std::string& name) {
  Handle attribute = open_attribute(object, name);
  double value = 0;
  checked(H5Aread(attribute.id(), H5T_NATIVE_DOUBLE, &value), "H5Aread", object, name);
  return value;
}

} // namespace yarnsim::output::h5
