// Preloaded into the CLI by a test (LD_PRELOAD): pthread_create fails with EAGAIN, as it does when the
// process has no memory left for a thread's stack or has reached its thread limit, after the first
// CONESHADOW_THREADS_ALLOWED calls (0: the first one already fails).
#include <dlfcn.h>
#include <errno.h>
#include <pthread.h>

#include <atomic>
#include <cstdlib>

extern "C" int pthread_create(pthread_t* thread, const pthread_attr_t* attr, void* (*start)(void*),
                              void* arg) noexcept {  // as glibc declares it
  using Create = int (*)(pthread_t*, const pthread_attr_t*, void* (*)(void*), void*);
  static const Create real = reinterpret_cast<Create>(dlsym(RTLD_NEXT, "pthread_create"));
  static std::atomic<long> calls{0};
  const char* allowed = std::getenv("CONESHADOW_THREADS_ALLOWED");
  if (allowed && calls.fetch_add(1) >= std::atol(allowed)) return EAGAIN;
  return real(thread, attr, start, arg);
}
