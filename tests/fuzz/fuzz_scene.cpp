// Fuzz target: the scene parser with --set overrides (src/scene/scene.hpp).
//
// Input: scene YAML, optionally followed by a line "#--set" and up to 8 lines KEY=VALUE,
// each given to parse_override() and then, together, to parse_scene_text(). The separator
// is a YAML comment, so a seed is still a valid scene file as a whole.
//
// Expected outcome for bad input: InputError (core/error.hpp), the parser's documented error.
// Anything else is a finding: another exception type, a crash, a sanitizer report, a leak,
// a hang. A scene that parses must also re-parse from its own text as run (Scene::text, the
// YAML written into the results file) to the same text: otherwise the finding aborts here.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.hpp"
#include "scene/scene.hpp"

namespace {

constexpr std::string_view k_separator = "\n#--set\n";
constexpr std::size_t k_max_overrides = 8;

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_scene: %s\n%s\n", what, detail.c_str());
  std::abort();
}

void parse(const std::string& input) {
  const std::size_t cut = input.find(k_separator);
  const std::string text = input.substr(0, cut);
  std::vector<peristat::Override> overrides;
  if (cut != std::string::npos) {
    std::size_t start = cut + k_separator.size();
    while (start <= input.size() && overrides.size() < k_max_overrides) {
      std::size_t end = input.find('\n', start);
      if (end == std::string::npos) end = input.size();
      const std::string line = input.substr(start, end - start);
      if (!line.empty()) overrides.push_back(peristat::parse_override(line));
      start = end + 1;
    }
  }
  const peristat::Scene scene = peristat::parse_scene_text(text, "fuzz.yaml", overrides);
  try {
    const peristat::Scene again = peristat::parse_scene_text(scene.text, "as-run.yaml");
    if (again.text != scene.text)
      finding("the scene as run re-parses to another text", scene.text + "\n---\n" + again.text);
  } catch (const peristat::InputError& e) {
    finding("the scene as run does not re-parse", scene.text + "\n---\n" + e.what());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    parse(std::string(reinterpret_cast<const char*>(data), size));
  } catch (const peristat::InputError&) {
    // the documented outcome for bad input
  }
  return 0;
}
