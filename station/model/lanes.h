#pragma once

// Four doubles as one value ("lanes", GCC and Clang vector extensions) for
// the colon solver's loops over points (colon_solver.cc) and the AVX2 sweep
// of the block elimination (block_tridiagonal.cc); docs/model.md, "Speed".
// Internal to station/model.
//
// Each lane does the scalar formula's IEEE operations in the scalar code's
// order, Eigen's included (a dot product or a norm sums from the first
// coordinate; s (u u^T) is evaluated as (s u) u^T; a 3x3 matrix times a
// vector sums its first two rows from the left and its third from the
// right), and nothing is fused into an FMA: the results are bit for bit
// those of one point at a time, in the AVX2 build and in the baseline one,
// so a replay stays exact on any x86-64.
#include <cstring>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "station/model/compiled_model.h"

#if defined(__GNUC__) && !defined(__clang__)
// Lanes are 32 bytes; no function takes or returns them (see
// VES_LANE_FUNCTION in colon_solver.cc), so GCC's note that AVX changes how
// they are passed does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

namespace ves::model::internal {

typedef double Lanes __attribute__((vector_size(4 * sizeof(double))));
// Four doubles of an array, at any double's alignment. Not may_alias: GCC
// takes a vector of doubles to alias doubles (every array read or written
// this way holds doubles) and nothing else, so it keeps the arrays' data
// pointers in registers; with may_alias it would read them again after
// every store (Clang takes any vector access to alias anything).
typedef double LanesInMemory
    __attribute__((vector_size(4 * sizeof(double)), aligned(alignof(double))));
using LaneMask = decltype(Lanes{} < Lanes{});
inline constexpr int kLanes = 4;
static_assert(kLanes <= kColonLanePadding, "the colon's arrays must hold a whole last group");

}  // namespace ves::model::internal

#define VES_LOAD(array, i) (Lanes(*reinterpret_cast<const LanesInMemory*>((array).data() + (i))))
#define VES_STORE_AT(pointer, value) (*reinterpret_cast<LanesInMemory*>(pointer) = (value))
#define VES_STORE(array, i, value) VES_STORE_AT((array).data() + (i), value)
// Lanes where mask is set take a, the others b.
#define VES_SELECT(mask, a, b) ((Lanes)(((mask) & (LaneMask)(a)) | (~(mask) & (LaneMask)(b))))
#define VES_ANY(mask) (((mask)[0] | (mask)[1] | (mask)[2] | (mask)[3]) != 0)
