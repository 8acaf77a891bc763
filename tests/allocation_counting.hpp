#pragma once
// Allocation counting for the tests that prove a real-time path allocates nothing.
//
// Replaces this executable's global allocation functions, so include it in exactly one
// source file of a test executable. Counts every form of operator new and, outside
// sanitizer builds on glibc, the malloc family too (Eigen allocates with malloc, not
// operator new); sanitizers interpose malloc themselves, so there only operator new is
// counted (HS_COUNT_MALLOC says which). Count with
//   hs::test::g_allocations = 0; hs::test::g_counting = true; ...; hs::test::g_counting = false;
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <new>

namespace hs::test {
inline std::atomic<bool> g_counting{false};
inline std::atomic<long> g_allocations{0};
inline void note_allocation() noexcept {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
}
inline void* counted_aligned(std::size_t n, std::align_val_t al) noexcept {
  note_allocation();
  const auto a = static_cast<std::size_t>(al);
  return std::aligned_alloc(a, ((n == 0 ? 1 : n) + a - 1) / a * a);
}
}  // namespace hs::test

void* operator new(std::size_t n) {
  hs::test::note_allocation();
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  hs::test::note_allocation();
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  hs::test::note_allocation();
  return std::malloc(n ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  hs::test::note_allocation();
  return std::malloc(n ? n : 1);
}
void* operator new(std::size_t n, std::align_val_t al) {
  if (void* p = hs::test::counted_aligned(n, al)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t al) {
  if (void* p = hs::test::counted_aligned(n, al)) return p;
  throw std::bad_alloc();
}
// The replaced operator new uses malloc, so free is the matching release; GCC cannot see
// that through the replacement and warns (at -O1 and above, as in the ASan build).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define HS_COUNT_MALLOC 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define HS_COUNT_MALLOC 0
#endif
#endif
#if !defined(HS_COUNT_MALLOC) && defined(__GLIBC__)
#define HS_COUNT_MALLOC 1
#endif
#ifndef HS_COUNT_MALLOC
#define HS_COUNT_MALLOC 0
#endif

#if HS_COUNT_MALLOC
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);
void* malloc(std::size_t n) noexcept {
  hs::test::note_allocation();
  return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) noexcept {
  hs::test::note_allocation();
  return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) noexcept {
  hs::test::note_allocation();
  return __libc_realloc(p, n);
}
void free(void* p) noexcept { __libc_free(p); }
int posix_memalign(void** out, std::size_t align, std::size_t n) noexcept {
  hs::test::note_allocation();
  void* p = __libc_memalign(align, n);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}
void* aligned_alloc(std::size_t align, std::size_t n) noexcept {
  hs::test::note_allocation();
  return __libc_memalign(align, n);
}
void* memalign(std::size_t align, std::size_t n) noexcept {
  hs::test::note_allocation();
  return __libc_memalign(align, n);
}
}
#endif
