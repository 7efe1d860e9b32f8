#pragma once

namespace dco {

// The CPUs the calling thread may run on: its affinity mask (taskset, systemd's CPUAffinity=, a
// cpuset), not every CPU the machine has, so a service kept off the renderer's cores sizes its
// threads for the cores it got. At least 1.
int usable_cpus();

}  // namespace dco
