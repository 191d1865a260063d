#include "assembly/contact_zone.hpp"

#include <algorithm>
#include <cstddef>

namespace peristat {

std::vector<char> contact_zone(const Model& model, const ContactSystem& contact,
                               const ContactZoneOptions& o) {
  const Index n = model.particles.size();
  if (o.layers <= 0 || n == 0) return {};
  std::vector<char> in(static_cast<std::size_t>(n), 0);
  Index size = 0;
  for (Index p = 0; p < n; ++p)
    if (contact.incident_begin(p) != contact.incident_end(p)) {
      in[p] = 1;
      ++size;
    }
  const double most = o.cap * static_cast<double>(n);
  if (size == 0 || static_cast<double>(size) > most) return {};
  // A bond exactly at the radius is in the stencil (a lattice distance, up to round-off).
  const double r2 = o.radius * o.radius * (1.0 + 1e-4);
  const Bonds& bonds = model.bonds;
  std::vector<char> grown;
  for (int layer = 0; layer < o.layers; ++layer) {
    grown = in;
    for (Index p = 0; p < n; ++p) {
      if (!in[p]) continue;
      for (Index b = bonds.start[p]; b < bonds.start[p + 1]; ++b)
        if (model.xi(p, b).squaredNorm() <= r2) grown[bonds.neighbour[b]] = 1;
    }
    const auto grown_size = static_cast<Index>(std::count(grown.begin(), grown.end(), char{1}));
    if (static_cast<double>(grown_size) > most) break;
    in.swap(grown);
  }
  return in;
}

}  // namespace peristat
