#include "io/h5.hpp"

#include <cstdio>
#include <functional>
#include <numeric>
#include <stdexcept>

namespace peristat::h5 {
namespace {

/// The innermost (most specific) description on HDF5's error stack, then clears it.
std::string hdf5_reason() {
  std::string reason;
  auto walker = [](unsigned n, const H5E_error2_t* err, void* data) -> herr_t {
    auto* out = static_cast<std::string*>(data);
    if (n == 0 && err != nullptr && err->desc != nullptr) *out = err->desc;
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, walker, &reason);
  H5Eclear2(H5E_DEFAULT);
  return reason;
}

hsize_t product(const std::vector<hsize_t>& dims) {
  return std::accumulate(dims.begin(), dims.end(), hsize_t{1}, std::multiplies<>());
}

/// A variable-length UTF-8 string type.
Handle vlen_string_type() {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  if (type.get() < 0 || H5Tset_size(type, H5T_VARIABLE) < 0 || H5Tset_cset(type, H5T_CSET_UTF8) < 0) {
    throw std::runtime_error("HDF5 could not create a string type: " + hdf5_reason());
  }
  return type;
}

/// File access properties for writing: without HDF5's advisory file lock, so that a
/// viewer or script holding the results file open cannot make a running solve fail.
/// (HDF5_USE_FILE_LOCKING=FALSE does the same for all HDF5 programs.)
Handle writer_access(const std::string& path) {
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  if (fapl.get() < 0) fail(path, "create file access properties");
#if H5_VERSION_GE(1, 10, 7)
  if (H5Pset_file_locking(fapl, false, true) < 0) fail(path, "turn off file locking");
#endif
  return fapl;
}

}  // namespace

void silence_errors() {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

void fail(const std::string& path, const std::string& what) {
  std::string message = "'" + path + "': HDF5 could not " + what;
  const std::string reason = hdf5_reason();
  if (!reason.empty()) message += ": " + reason;
  throw std::runtime_error(message);
}

// ---- File ---------------------------------------------------------------------------

File File::create(const std::string& path) {
  silence_errors();
  const Handle fapl = writer_access(path);
  const hid_t id = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
  if (id < 0) fail(path, "create the file");
  return File(path, Handle(id, H5Fclose));
}

File File::open(const std::string& path, bool writable) {
  silence_errors();
  const Handle fapl = writable ? writer_access(path) : Handle();
  const hid_t id =
      H5Fopen(path.c_str(), writable ? H5F_ACC_RDWR : H5F_ACC_RDONLY, writable ? fapl.get() : H5P_DEFAULT);
  if (id < 0) fail(path, "open the file");
  return File(path, Handle(id, H5Fclose));
}

void File::close() {
  if (m_handle.close() < 0) fail(m_path, "close (flush) the file");
}

hid_t File::check(hid_t id, const std::string& what) const {
  if (id < 0) fail(m_path, what);
  return id;
}

void File::check_status(herr_t status, const std::string& what) const {
  if (status < 0) fail(m_path, what);
}

// ---- groups and links ---------------------------------------------------------------

Handle File::create_group(hid_t loc, const std::string& name) const {
  return Handle(check(H5Gcreate2(loc, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                      "create group '" + name + "'"),
                H5Gclose);
}

Handle File::open_group(hid_t loc, const std::string& name) const {
  return Handle(check(H5Gopen2(loc, name.c_str(), H5P_DEFAULT), "open group '" + name + "'"), H5Gclose);
}

bool File::link_exists(hid_t loc, const std::string& name) const {
  const htri_t exists = H5Lexists(loc, name.c_str(), H5P_DEFAULT);
  if (exists < 0) fail(m_path, "look up '" + name + "'");
  return exists > 0;
}

bool File::attribute_exists(hid_t obj, const std::string& name) const {
  const htri_t exists = H5Aexists(obj, name.c_str());
  if (exists < 0) fail(m_path, "look up attribute '" + name + "'");
  return exists > 0;
}

std::vector<std::string> File::link_names(hid_t group) const {
  std::vector<std::string> names;
  auto collect = [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
    static_cast<std::vector<std::string>*>(data)->emplace_back(name);
    return 0;
  };
  hsize_t index = 0;
  check_status(H5Literate(group, H5_INDEX_NAME, H5_ITER_INC, &index, collect, &names), "list a group");
  return names;
}

void File::delete_link(hid_t loc, const std::string& name) const {
  check_status(H5Ldelete(loc, name.c_str(), H5P_DEFAULT), "delete '" + name + "'");
}

// ---- datasets -----------------------------------------------------------------------

void File::write_dataset(hid_t loc, const std::string& name, hid_t mem_type, hid_t file_type,
                         const void* data, const std::vector<hsize_t>& dims) const {
  const std::string what = "write dataset '" + name + "'";
  Handle space(check(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), what), H5Sclose);
  Handle dset(
      check(H5Dcreate2(loc, name.c_str(), file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), what),
      H5Dclose);
  if (product(dims) > 0) {
    check_status(H5Dwrite(dset, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), what);
  }
}

void File::write_doubles(hid_t loc, const std::string& name, const double* data,
                         const std::vector<hsize_t>& dims) const {
  write_dataset(loc, name, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, data, dims);
}

void File::write_ints(hid_t loc, const std::string& name, const int* data,
                      const std::vector<hsize_t>& dims) const {
  static_assert(sizeof(int) == 4, "int is written as a 32-bit integer");
  write_dataset(loc, name, H5T_NATIVE_INT, H5T_STD_I32LE, data, dims);
}

std::vector<hsize_t> File::shape(hid_t loc, const std::string& name) const {
  const std::string what = "read the shape of dataset '" + name + "'";
  Handle dset(check(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), what), H5Dclose);
  Handle space(check(H5Dget_space(dset), what), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 0) fail(m_path, what);
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  check_status(H5Sget_simple_extent_dims(space, dims.data(), nullptr), what);
  return dims;
}

/// A damaged file can claim any shape, and the buffer is allocated before HDF5 reads (and
/// fails on) data that is not there: the shape is checked against the bytes the file can
/// hold first. Contiguous and compact data are stored as they are; chunked data may be
/// compressed, by at most deflate's 1032:1. Data kept outside the file (external or virtual
/// storage, never in a peristat file) is refused.
std::size_t File::element_count(hid_t loc, const std::string& name) const {
  const std::vector<hsize_t> dims = shape(loc, name);
  const std::string what = "read dataset '" + name + "'";
  Handle dset(check(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), what), H5Dclose);
  Handle type(check(H5Dget_type(dset), what), H5Tclose);
  Handle plist(check(H5Dget_create_plist(dset), what), H5Pclose);
  const H5D_layout_t layout = H5Pget_layout(plist);
  const int n_external = H5Pget_external_count(plist);
  hsize_t file_bytes = 0;
  check_status(H5Fget_filesize(m_handle, &file_bytes), what);
  if (layout < 0 || n_external < 0) fail(m_path, what);
  if (layout == H5D_VIRTUAL || n_external > 0) {
    throw std::runtime_error("'" + m_path + "': dataset '" + name + "' keeps its data outside the file");
  }
  double bytes = static_cast<double>(H5Tget_size(type));  // a double cannot overflow here
  for (const hsize_t d : dims) bytes *= static_cast<double>(d);
  const double ratio = layout == H5D_CHUNKED ? 1032.0 : 1.0;
  if (bytes > ratio * static_cast<double>(file_bytes)) {
    char text[160];
    std::snprintf(text, sizeof text, "claims %.4g bytes, more than the %llu of the file can hold", bytes,
                  static_cast<unsigned long long>(file_bytes));
    throw std::runtime_error("'" + m_path + "': dataset '" + name + "' " + text + " (is the file damaged?)");
  }
  return static_cast<std::size_t>(product(dims));
}

void File::read_dataset(hid_t loc, const std::string& name, hid_t mem_type, void* out,
                        std::size_t n_expected) const {
  const std::string what = "read dataset '" + name + "'";
  Handle dset(check(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), what), H5Dclose);
  if (n_expected > 0) {
    check_status(H5Dread(dset, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out), what);
  }
}

std::vector<double> File::read_doubles(hid_t loc, const std::string& name) const {
  std::vector<double> values(element_count(loc, name));
  read_dataset(loc, name, H5T_NATIVE_DOUBLE, values.data(), values.size());
  return values;
}

std::vector<int> File::read_ints(hid_t loc, const std::string& name) const {
  std::vector<int> values(element_count(loc, name));
  read_dataset(loc, name, H5T_NATIVE_INT, values.data(), values.size());
  return values;
}

// ---- attributes ---------------------------------------------------------------------

void File::write_scalar_attribute(hid_t obj, const std::string& name, hid_t mem_type, hid_t file_type,
                                  const void* value) const {
  const std::string what = "write attribute '" + name + "'";
  Handle space(check(H5Screate(H5S_SCALAR), what), H5Sclose);
  Handle attr(check(H5Acreate2(obj, name.c_str(), file_type, space, H5P_DEFAULT, H5P_DEFAULT), what),
              H5Aclose);
  check_status(H5Awrite(attr, mem_type, value), what);
}

void File::write_attribute(hid_t obj, const std::string& name, double value) const {
  write_scalar_attribute(obj, name, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, &value);
}

void File::write_attribute(hid_t obj, const std::string& name, int value) const {
  write_scalar_attribute(obj, name, H5T_NATIVE_INT, H5T_STD_I32LE, &value);
}

void File::write_attribute(hid_t obj, const std::string& name, const std::string& value) const {
  const Handle type = vlen_string_type();
  const char* text = value.c_str();
  write_scalar_attribute(obj, name, type, type, &text);
}

void File::write_attribute(hid_t obj, const std::string& name, const std::vector<std::string>& values) const {
  const std::string what = "write attribute '" + name + "'";
  const Handle type = vlen_string_type();
  const hsize_t n = values.size();
  Handle space(check(H5Screate_simple(1, &n, nullptr), what), H5Sclose);
  Handle attr(check(H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT), what), H5Aclose);
  std::vector<const char*> texts;
  texts.reserve(values.size());
  for (const auto& v : values) texts.push_back(v.c_str());
  if (!texts.empty()) check_status(H5Awrite(attr, type, texts.data()), what);
}

Handle File::open_attribute(hid_t obj, const std::string& name, const std::string& what) const {
  Handle attr(check(H5Aopen(obj, name.c_str(), H5P_DEFAULT), what), H5Aclose);
  Handle type(check(H5Aget_type(attr), what), H5Tclose);
  Handle space(check(H5Aget_space(attr), what), H5Sclose);
  const hssize_t n_points = H5Sget_simple_extent_npoints(space);
  const htri_t is_variable = H5Tis_variable_str(type);
  if (n_points < 0 || is_variable < 0) fail(m_path, what);
  // A variable-length value is stored as a global heap ID: a 4-byte length, an address, a 4-byte index.
  std::size_t element_bytes = H5Tget_size(type);
  if (is_variable > 0 || H5Tget_class(type) == H5T_VLEN) {
    Handle plist(check(H5Fget_create_plist(m_handle), what), H5Pclose);
    std::size_t address_bytes = 0;
    check_status(H5Pget_sizes(plist, &address_bytes, nullptr), what);
    element_bytes = 8 + address_bytes;
  }
  // Divided, not multiplied: a damaged shape can make n_points x element_bytes overflow.
  const hsize_t stored = H5Aget_storage_size(attr);
  if (element_bytes == 0 || stored % element_bytes != 0 ||
      stored / element_bytes != static_cast<hsize_t>(n_points)) {
    throw std::runtime_error("'" + m_path + "': attribute '" + name + "' holds " + std::to_string(stored) +
                             " bytes for " + std::to_string(n_points) + " values of " +
                             std::to_string(element_bytes) + " bytes (is the file damaged?)");
  }
  return attr;
}

double File::read_double_attribute(hid_t obj, const std::string& name) const {
  const std::string what = "read attribute '" + name + "'";
  Handle attr = open_attribute(obj, name, what);
  double value = 0.0;
  check_status(H5Aread(attr, H5T_NATIVE_DOUBLE, &value), what);
  return value;
}

std::vector<std::string> File::read_string_array_attribute(hid_t obj, const std::string& name) const {
  const std::string what = "read string attribute '" + name + "'";
  Handle attr = open_attribute(obj, name, what);
  Handle file_type(check(H5Aget_type(attr), what), H5Tclose);
  if (H5Tget_class(file_type) != H5T_STRING) {
    throw std::runtime_error("attribute '" + name + "' in '" + m_path + "' is not a string");
  }
  Handle space(check(H5Aget_space(attr), what), H5Sclose);
  const hssize_t n_points = H5Sget_simple_extent_npoints(space);
  if (n_points < 0) fail(m_path, what);
  const auto n = static_cast<std::size_t>(n_points);
  std::vector<std::string> values;
  values.reserve(n);
  if (n == 0) return values;

  const htri_t is_variable = H5Tis_variable_str(file_type);
  if (is_variable < 0) fail(m_path, what);
  if (is_variable > 0) {
    const Handle mem_type = vlen_string_type();
    std::vector<char*> texts(n, nullptr);
    check_status(H5Aread(attr, mem_type, texts.data()), what);
    for (char* t : texts) values.emplace_back(t != nullptr ? t : "");
    H5Dvlen_reclaim(mem_type, space, H5P_DEFAULT, texts.data());
    return values;
  }
  const std::size_t width = H5Tget_size(file_type);
  if (width == 0) fail(m_path, what);
  Handle mem_type(check(H5Tcopy(H5T_C_S1), what), H5Tclose);
  check_status(H5Tset_size(mem_type, width), what);
  std::vector<char> buffer(n * width, '\0');
  check_status(H5Aread(attr, mem_type, buffer.data()), what);
  for (std::size_t i = 0; i < n; ++i) {
    const char* begin = buffer.data() + i * width;
    std::size_t length = 0;
    while (length < width && begin[length] != '\0') ++length;
    values.emplace_back(begin, length);
  }
  return values;
}

std::string File::read_string_attribute(hid_t obj, const std::string& name) const {
  std::vector<std::string> values = read_string_array_attribute(obj, name);
  if (values.size() != 1) {
    throw std::runtime_error("attribute '" + name + "' in '" + m_path + "' is not a single string");
  }
  return std::move(values.front());
}

}  // namespace peristat::h5
