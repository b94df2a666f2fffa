// The method registry: see registry.h.
#include "method/registry.h"

#include <algorithm>

namespace cs {

namespace {
std::vector<MethodInfo>& table() {
  static std::vector<MethodInfo> methods;
  return methods;
}
}  // namespace

void registerMethod(MethodInfo info) {
  CS_CHECK(!info.name.empty() && info.make, "a method needs a name and a factory");
  if (findMethod(info.name)) throw Error("a method named '" + info.name + "' is registered twice", "method registry");
  table().push_back(std::move(info));
}

bool unregisterMethod(const std::string& name) {
  auto& t = table();
  auto it = std::find_if(t.begin(), t.end(), [&](const MethodInfo& m) { return m.name == name; });
  if (it == t.end()) return false;
  t.erase(it);
  return true;
}

const std::vector<MethodInfo>& registeredMethods() {
  return table();
}

std::vector<std::string> registeredMethodNames() {
  std::vector<std::string> names;
  for (const MethodInfo& m : registeredMethods()) names.push_back(m.name);
  return names;
}

const MethodInfo* findMethod(const std::string& name) {
  for (const MethodInfo& m : table())
    if (equalsIgnoringCase(m.name, name)) return &m;
  return nullptr;
}

const MethodInfo& methodOrUsageError(const std::string& name) {
  if (const MethodInfo* m = findMethod(name)) return *m;
  std::string all;
  const std::vector<std::string> names = registeredMethodNames();
  for (const std::string& n : names) all += (all.empty() ? "" : ", ") + n;
  throw UsageError("unknown method '" + name + "'" + didYouMean(name, names) + " (methods: " + all + ")");
}

const MethodInfo& referenceMethod() {
  for (const MethodInfo& m : table())
    if (m.reference) return m;
  throw Error("no reference method is registered", "method registry");
}

std::string unsupportedOn(const MethodInfo& info, const vk::Context& ctx, const Settings& settings) {
  return info.unsupported ? info.unsupported(ctx, settings) : std::string();
}

std::vector<SweepPoint> sweepOf(const MethodInfo& info, const Settings& settings) {
  if (info.sweep) return info.sweep(settings);
  return {{info.name, settings, true}};  // a method without a sweep runs its defaults
}

std::vector<SweepPoint> dynamicRowsOf(const MethodInfo& info, const Settings& settings, bool staticGeometry) {
  if (info.dynamicRows) return info.dynamicRows(settings, staticGeometry);
  return {{info.name, settings}};
}

}  // namespace cs
