// Interposes malloc/calloc/realloc in a test executable and counts calls while armed.
// glibc exports __libc_malloc & co., so the real allocator stays reachable.
#pragma once

#include <cstddef>

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);
}

namespace counting {
inline bool armed = false;
inline long count = 0;
}  // namespace counting

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
