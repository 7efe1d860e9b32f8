#pragma once

namespace dco::bench {

// `dco-bench ipc ...`: publish-to-client latency of the shared-memory depth ring for several
// client processes and frame rates, next to sending the same frames inline over LCM udpm in the
// same run. argv[0] is "ipc". Returns the exit status.
int run_ipc_bench(int argc, char** argv);

}  // namespace dco::bench
