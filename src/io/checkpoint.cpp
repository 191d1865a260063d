#include "io/checkpoint.hpp"

#include <filesystem>
#include <stdexcept>
#include <vector>

#include "io/h5.hpp"
#include "io/safe_write.hpp"

namespace peristat {

namespace {
/// Archive keys hold '/' (e.g. "contact/slip"); dataset names in the root group do not.
std::string dataset_name(const std::string& key) {
  std::string name = key;
  for (char& c : name)
    if (c == '/') c = ':';
  return name;
}
std::string key_of(const std::string& name) {
  std::string key = name;
  for (char& c : key)
    if (c == ':') c = '/';
  return key;
}
constexpr const char* kFormat = "peristat checkpoint 1";
}  // namespace

void write_checkpoint(const std::string& path, const StateArchive& archive) {
  const std::string temporary = path + ".tmp";
  {
    const io::SignalBlocker hold_signals;
    h5::File file = h5::File::create(temporary);
    file.write_attribute(file.id(), "format", std::string(kFormat));
    std::vector<std::string> keys;
    for (const auto& [key, text] : archive.texts) {
      file.write_attribute(file.id(), "text:" + key, text);
      keys.push_back(key);
    }
    if (!keys.empty()) file.write_attribute(file.id(), "texts", keys);
    for (const auto& [key, values] : archive.arrays)
      file.write_doubles(file.id(), dataset_name(key), values.data(), {static_cast<hsize_t>(values.size())});
    file.close();
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) throw std::runtime_error("cannot rename '" + temporary + "' to '" + path + "': " + error.message());
}

StateArchive read_checkpoint(const std::string& path) {
  if (!std::filesystem::exists(path))
    throw InputError(path + ": no checkpoint to resume from (the run never completed a load step there)");
  StateArchive archive;
  try {
    h5::File file = h5::File::open(path, false);
    if (!file.attribute_exists(file.id(), "format") || file.read_string_attribute(file.id(), "format") != kFormat)
      throw InputError(path + ": not a peristat checkpoint (format attribute missing or unknown)");
    for (const std::string& name : file.link_names(file.id())) archive.arrays[key_of(name)] = file.read_doubles(file.id(), name);
    if (file.attribute_exists(file.id(), "texts"))
      for (const std::string& key : file.read_string_array_attribute(file.id(), "texts"))
        archive.texts[key] = file.read_string_attribute(file.id(), "text:" + key);
  } catch (const InputError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw InputError(std::string("cannot read the checkpoint: ") + e.what());
  }
  return archive;
}

}  // namespace peristat
