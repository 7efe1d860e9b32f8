#ifndef DCO_TEST_C_ABI_SMOKE_H
#define DCO_TEST_C_ABI_SMOKE_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Opens the ring at path, copies the newest frame; returns the dco_status. */
int dco_test_c_read(const char* path, uint64_t* frame_seq, float* first_depth);

#ifdef __cplusplus
}
#endif

#endif
