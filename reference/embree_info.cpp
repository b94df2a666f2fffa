// Embree in the method registry: the judge's reference, also a method a report lists (its row is the
// reference run itself).
#include "method/registry.h"
#include "reference/embree_reference.h"

namespace cs {

MethodInfo embreeMethodInfo() {
  MethodInfo m;
  m.name = "embree";
  m.summary = "Embree ray tracing on the CPU: the reference every method is judged against";
  m.reference = true;
  m.exact = true;
  m.usesDevice = false;
  m.make = [](vk::Context*, const Settings&) -> std::unique_ptr<ShadowMethod> {
    return std::make_unique<EmbreeReference>();
  };
  return m;
}

}  // namespace cs
