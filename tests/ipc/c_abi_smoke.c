/* Compiled as C: dco/client.h must be plain C, and a C caller must be able to read a frame. */
#include <dco/client.h>
#include <stdlib.h>
#include <string.h>

#include "c_abi_smoke.h"

int dco_test_c_read(const char* path, uint64_t* frame_seq, float* first_depth) {
  dco_client_options options;
  dco_client* client = NULL;
  dco_frame_view view;
  dco_frame_buffer buffer;
  dco_status status;

  dco_client_options_init(&options);
  options.path = path;
  status = dco_client_open(&options, &client);
  if (status != DCO_OK) return (int)status;

  dco_frame_view_init(&view);
  status = dco_client_latest(client, &view);
  if (status == DCO_OK) {
    dco_frame_buffer_init(&buffer);
    buffer.depth_stride = view.info.width * sizeof(float);
    buffer.depth_capacity = buffer.depth_stride * view.info.height;
    buffer.depth = (float*)malloc(buffer.depth_capacity);
    status = dco_client_copy(client, &view, &buffer);
    if (status == DCO_OK) {
      *frame_seq = view.info.frame_seq;
      *first_depth = buffer.depth[0];
    }
    free(buffer.depth);
  }
  dco_client_close(client);
  return (int)status;
}
