#pragma once

// Functions marked DCO_HD compile for the CPU and, under nvcc, for the GPU too: the per-pixel
// math the CPU stages and the CUDA kernels share.
#ifdef __CUDACC__
#define DCO_HD __host__ __device__
#else
#define DCO_HD
#endif
