/* Built against an installed libdco-client: a missing ring must give DCO_E_NO_SEGMENT. */
#include <dco/client.h>
#include <stdio.h>
#include <string.h>

int main(void) {
  dco_client_options options;
  dco_client* client = NULL;
  dco_status status;
  dco_client_options_init(&options);
  options.path = "/nonexistent/dco/depth.shm";
  status = dco_client_open(&options, &client);
  if (status != DCO_E_NO_SEGMENT || client != NULL) return 1;
  if (strstr(dco_client_last_error(), "/nonexistent/dco/depth.shm") == NULL) return 1;
  printf("%s\n", dco_client_strerror(status));
  return 0;
}
