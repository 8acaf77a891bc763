#pragma once
// The core's floating-point peak, measured: independent chains of fused multiply-adds
// (enough to cover the FMA latency on every issue port), so the loop runs at the FMA
// throughput of one core. No torch, no Eigen here.
#include <cstdint>
#include <string>
#include <vector>

namespace hs::bench {

enum class FmaIsa { Scalar, Avx2, Avx512 };
enum class FmaType { F32, F64 };

const char* isa_name(FmaIsa isa);
// Whether this CPU can run the kernel (runtime check with __builtin_cpu_supports).
bool fma_supported(FmaIsa isa);
// Runs `rounds` rounds of the kernel; returns a value that depends on every chain (so the
// work cannot be removed). Precondition: fma_supported(isa).
double fma_kernel(FmaIsa isa, FmaType type, std::int64_t rounds);
// Floating-point operations of one round (2 per multiply-add).
std::int64_t fma_flops_per_round(FmaIsa isa, FmaType type);

}  // namespace hs::bench
