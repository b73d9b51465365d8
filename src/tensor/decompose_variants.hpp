#pragma once
// The per-level entry points of the decomposition kernels, gathered into DecomposeKernels tables
// by decompose_kernel.cpp. Private to src/tensor.
#include <cstdint>

#include "tensor/decompose_kernel.hpp"

namespace strata::tensor::detail {

// decompose_gemm.cpp
void gemm_generic(const DGemmArgs& g);
void gemm_avx2(const DGemmArgs& g);
void gemm_avx512(const DGemmArgs& g);

// decompose_gram.cpp
void gram_generic(const DGramArgs& a);
void gram_avx2(const DGramArgs& a);
void gram_avx512(const DGramArgs& a);
void gram_i16_generic(const std::int16_t* x, std::int64_t n, std::int64_t len, double* g);
void gram_i16_avx2(const std::int16_t* x, std::int64_t n, std::int64_t len, double* g);
void gram_i16_avx512(const std::int16_t* x, std::int64_t n, std::int64_t len, double* g);
double sum_squares_generic(const double* x, std::int64_t n);
double sum_squares_avx2(const double* x, std::int64_t n);
double sum_squares_avx512(const double* x, std::int64_t n);
double sum_squares_f_generic(const float* x, std::int64_t n);
double sum_squares_f_avx2(const float* x, std::int64_t n);
double sum_squares_f_avx512(const float* x, std::int64_t n);

// decompose_eigen.cpp
bool leading_eigen_generic(double* a, std::int64_t n, std::int64_t r, double* u, double* work);
bool leading_eigen_avx2(double* a, std::int64_t n, std::int64_t r, double* u, double* work);
bool leading_eigen_avx512(double* a, std::int64_t n, std::int64_t r, double* u, double* work);

}  // namespace strata::tensor::detail
