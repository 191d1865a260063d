#include "materials/family_kernel.hpp"

#include "materials/osb.hpp"

namespace peristat {

std::unique_ptr<FamilyKernel> make_family_kernel(const Material& material) {
  return std::make_unique<OsbKernel>(material);
}

}  // namespace peristat
