#pragma once
// Explicit, optional parallelism. Every parallel function of rangenav takes its thread count as
// an argument (default 1, serial); there is no process-wide thread state. OpenMP runs the loops
// when the compiler has it enabled (the CMake target links OpenMP::OpenMP_CXX where it is
// found); without it every loop runs serially and gives the same result.
//
// Determinism: work is cut into blocks whose size does not depend on the thread count; a block
// writes only its own output slot and is processed in order, and results of blocks are combined in
// block order afterwards. So 1 and N threads give the same bits.

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "rangenav/core/error.hpp"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace rangenav {

/// Whether this build runs loops on several threads (OpenMP enabled); when false a thread count
/// above 1 is accepted and the work runs serially.
inline constexpr bool parallel_enabled =
#if defined(_OPENMP)
    true;
#else
    false;
#endif

namespace detail {

/// Throws invalid_argument unless num_threads >= 1.
inline void require_threads(std::string_view where, int num_threads) {
  if (num_threads < 1) throw_invalid_argument(where, "num_threads", num_threads, "must be >= 1");
}

/// The number of blocks of `block` items that cover n items.
[[nodiscard]] constexpr std::size_t block_count(std::size_t n, std::size_t block) {
  return (n + block - 1) / block;
}

/// Calls f(b, begin, end, thread) for every block b of `block` consecutive items of [0, n), on
/// up to num_threads threads; `thread` in [0, num_threads) names the calling thread (to pick its
/// scratch buffer). Blocks are handed out dynamically: each writes only its own output, so the
/// schedule does not change the result. f must not throw.
template <class F>
void for_each_block(std::size_t n, std::size_t block, int num_threads, F&& f) {
  const std::size_t blocks = block_count(n, block);
  const auto run = [&](std::size_t b, int thread) {
    const std::size_t begin = b * block;
    const std::size_t end = begin + block < n ? begin + block : n;
    f(b, begin, end, thread);
  };
#if defined(_OPENMP)
  if (num_threads > 1 && blocks > 1) {
    const auto count = static_cast<std::int64_t>(blocks);
#pragma omp parallel for num_threads(num_threads) schedule(dynamic, 1)
    for (std::int64_t b = 0; b < count; ++b)
      run(static_cast<std::size_t>(b), omp_get_thread_num());
    return;
  }
#else
  (void)num_threads;
#endif
  for (std::size_t b = 0; b < blocks; ++b)
    run(b, 0);
}

/// The sum over [0, n) of f(begin, end), a partial sum of one block of `block` items, on up to
/// num_threads threads: the blocks' partial sums are added in block order (T has +=), so the
/// result does not depend on the thread count. A single block is f(0, n) itself.
template <class T, class F>
[[nodiscard]] T sum_blocks(std::size_t n, std::size_t block, int num_threads, F&& f) {
  const std::size_t blocks = block_count(n, block);
  if (blocks <= 1) return f(std::size_t(0), n);
  std::vector<T> partial(blocks);
  for_each_block(
      n, block, num_threads,
      [&](std::size_t b, std::size_t begin, std::size_t end, int) { partial[b] = f(begin, end); });
  T total = partial[0];
  for (std::size_t b = 1; b < blocks; ++b)
    total += partial[b];
  return total;
}

}  // namespace detail
}  // namespace rangenav
