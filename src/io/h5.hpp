// Private to src/io: a thin RAII layer over the HDF5 C API. Every failure becomes a
// std::runtime_error naming the file, the object and HDF5's own reason.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <hdf5.h>

namespace peristat::h5 {

/// Owns one hid_t and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer closer) : m_id(id), m_closer(closer) {}
  ~Handle() { reset(); }
  Handle(Handle&& other) noexcept
      : m_id(std::exchange(other.m_id, H5I_INVALID_HID)), m_closer(other.m_closer) {}
  Handle& operator=(Handle&& other) noexcept {
    if (this != &other) {
      reset();
      m_id = std::exchange(other.m_id, H5I_INVALID_HID);
      m_closer = other.m_closer;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;

  hid_t get() const { return m_id; }
  operator hid_t() const { return m_id; }  // NOLINT(google-explicit-constructor): C API glue

  /// Closes now and reports failure (H5Fclose is where buffered data reaches the disk).
  herr_t close() {
    herr_t status = 0;
    if (m_id >= 0 && m_closer != nullptr) status = m_closer(m_id);
    m_id = H5I_INVALID_HID;
    return status;
  }

 private:
  void reset() { (void)close(); }
  hid_t m_id = H5I_INVALID_HID;
  Closer m_closer = nullptr;
};

/// Turns off HDF5's automatic error printing (idempotent; per thread in thread-safe builds).
void silence_errors();

/// Throws std::runtime_error("'<path>': HDF5 could not <what>: <HDF5 reason>").
[[noreturn]] void fail(const std::string& path, const std::string& what);

/// An open HDF5 file plus its path, so that every error message can name it.
class File {
 public:
  static File create(const std::string& path);  ///< truncates
  static File open(const std::string& path, bool writable);

  const std::string& path() const { return m_path; }
  hid_t id() const { return m_handle.get(); }
  /// Closes the file, throwing if HDF5 fails to flush it.
  void close();

  // ---- groups and links -----------------------------------------------------------
  Handle create_group(hid_t loc, const std::string& name) const;
  Handle open_group(hid_t loc, const std::string& name) const;
  bool link_exists(hid_t loc, const std::string& name) const;
  bool attribute_exists(hid_t obj, const std::string& name) const;
  /// Names of the links directly under `group`, in HDF5 name order.
  std::vector<std::string> link_names(hid_t group) const;
  void delete_link(hid_t loc, const std::string& name) const;

  // ---- datasets -------------------------------------------------------------------
  /// Contiguous dataset of shape `dims` holding `data` (row-major, size = prod(dims)).
  void write_doubles(hid_t loc, const std::string& name, const double* data,
                     const std::vector<hsize_t>& dims) const;
  void write_ints(hid_t loc, const std::string& name, const int* data,
                  const std::vector<hsize_t>& dims) const;
  /// Shape of a dataset.
  std::vector<hsize_t> shape(hid_t loc, const std::string& name) const;
  /// Whole dataset converted to double / int.
  std::vector<double> read_doubles(hid_t loc, const std::string& name) const;
  std::vector<int> read_ints(hid_t loc, const std::string& name) const;

  // ---- attributes -----------------------------------------------------------------
  void write_attribute(hid_t obj, const std::string& name, double value) const;
  void write_attribute(hid_t obj, const std::string& name, int value) const;
  void write_attribute(hid_t obj, const std::string& name, const std::string& value) const;
  void write_attribute(hid_t obj, const std::string& name, const std::vector<std::string>& values) const;
  double read_double_attribute(hid_t obj, const std::string& name) const;
  /// Scalar string attribute, variable or fixed length.
  std::string read_string_attribute(hid_t obj, const std::string& name) const;
  /// 1-D string array attribute, variable or fixed length.
  std::vector<std::string> read_string_array_attribute(hid_t obj, const std::string& name) const;

 private:
  File(std::string path, Handle handle) : m_path(std::move(path)), m_handle(std::move(handle)) {}
  hid_t check(hid_t id, const std::string& what) const;
  void check_status(herr_t status, const std::string& what) const;
  void write_dataset(hid_t loc, const std::string& name, hid_t mem_type, hid_t file_type, const void* data,
                     const std::vector<hsize_t>& dims) const;
  void read_dataset(hid_t loc, const std::string& name, hid_t mem_type, void* out,
                    std::size_t n_expected) const;
  /// Elements of a dataset; throws when its shape claims more bytes than the file can hold.
  std::size_t element_count(hid_t loc, const std::string& name) const;
  /// Opens an attribute after checking that the file stored as many bytes as its shape and
  /// type need (HDF5 1.10 copies by shape and type without checking: a heap-buffer-overflow
  /// in H5A__read on a damaged file).
  Handle open_attribute(hid_t obj, const std::string& name, const std::string& what) const;
  void write_scalar_attribute(hid_t obj, const std::string& name, hid_t mem_type, hid_t file_type,
                              const void* value) const;

  std::string m_path;
  Handle m_handle;
};

}  // namespace peristat::h5
