// A non-owning reference to a callable, for a callback that is called only before the function taking it
// returns (a recording's stage boundaries, the engine's delivery of each light's mask): unlike
// std::function it never copies the callable, so a lambda with captures costs no allocation. The
// callable must outlive the reference: pass a lambda straight to the call, or name it first.
#pragma once
#include <cstddef>
#include <memory>
#include <type_traits>
#include <utility>

namespace cs {

template <class Signature>
class FunctionRef;

template <class R, class... Args>
class FunctionRef<R(Args...)> {
 public:
  // An empty reference (operator bool is false): test it before calling, as a std::function.
  FunctionRef(std::nullptr_t) noexcept {}  // NOLINT: implicit, as std::function's
  template <class F, class = std::enable_if_t<!std::is_same_v<std::decay_t<F>, FunctionRef> &&
                                              std::is_invocable_r_v<R, F&, Args...>>>
  FunctionRef(F&& f) noexcept  // NOLINT: implicit, so a lambda is passed as it is
      : object_(const_cast<void*>(static_cast<const void*>(std::addressof(f)))),
        call_([](void* object, Args... args) -> R {
          return (*static_cast<std::add_pointer_t<F>>(object))(std::forward<Args>(args)...);
        }) {}

  explicit operator bool() const { return call_ != nullptr; }
  R operator()(Args... args) const { return call_(object_, std::forward<Args>(args)...); }

 private:
  void* object_ = nullptr;
  R (*call_)(void*, Args...) = nullptr;
};

}  // namespace cs
