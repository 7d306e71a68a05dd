// Interposes malloc/calloc/realloc in a test executable and counts calls while armed.
// glibc exports __libc_malloc & co., so the real allocator stays reachable.
// Under AddressSanitizer (make test-asan) the sanitizer owns malloc: interposing it would hand ASan pointers it
// never allocated, so the count comes from ASan's allocation hook instead (every malloc, calloc, realloc, new).
#pragma once

#include <cstddef>

#if defined(__SANITIZE_ADDRESS__)
#define TENDYN_COUNTING_WITH_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TENDYN_COUNTING_WITH_ASAN 1
#endif
#endif

namespace counting {
inline bool armed = false;
inline long count = 0;
}  // namespace counting

#ifdef TENDYN_COUNTING_WITH_ASAN
// <sanitizer/allocator_interface.h> is not installed with every compiler: the one declaration needed
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*, std::size_t),
                                                         void (*free_hook)(const volatile void*));

namespace counting {
inline void on_malloc(const volatile void*, std::size_t) {
  if (armed) ++count;
}
inline void on_free(const volatile void*) {}
inline const int hooks_installed = __sanitizer_install_malloc_and_free_hooks(on_malloc, on_free);
}  // namespace counting
#else
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);
}

extern "C" {
void* malloc(std::size_t n) {
  if (counting::armed) ++counting::count;
  return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) {
  if (counting::armed) ++counting::count;
  return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) {
  if (counting::armed) ++counting::count;
  return __libc_realloc(p, n);
}
void free(void* p) { __libc_free(p); }
}
#endif
