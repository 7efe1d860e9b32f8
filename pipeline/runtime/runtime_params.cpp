#include "dco/pipeline/runtime/runtime_params.hpp"

#include <sched.h>

#include <algorithm>
#include <string_view>

#include "dco/core/config.hpp"
#include "dco/core/error.hpp"
#include "dco/core/usable_cpus.hpp"

namespace dco::pipeline::runtime {

void register_params(ConfigSchema& s, RuntimeParams& p) {
  s.add("runtime.threads", &p.threads, 0, 3,
        "stage threads: 1 all in one, 2 stereo | contour+densify, 3 stereo | contour | densify; "
        "0 = 3 where 4 or more CPUs are usable, else 2");
  s.add("runtime.affinity", &p.affinity, {},
        "CPUs for the stage threads, e.g. \"0,1\" (thread i on entry i mod n); empty = any");
  s.add("runtime.opencv_threads", &p.opencv_threads, 0, 256,
        "threads of OpenCV's parallel loops (DIS flow) while the runtime runs, process-wide; "
        "0 = 1 when the stage threads are as many as the usable CPUs, else OpenCV's choice; "
        "dcod sets it as it starts and keeps it until it restarts");
  s.add("runtime.queue_depth", &p.queue_depth, 1, 8,
        "frames each queue between stage threads holds (each one is a frame of latency)");
  s.add("runtime.entry_deadline_ms", &p.entry_deadline_ms, 0.0, 1000.0,
        "a frame that waited longer than this at the entry only lends its image to its "
        "neighbours' flow, so every depth map starts this soon after its entry (or "
        "entry_deadline_share of the frame interval, when that is longer); 0 = no deadline");
  s.add("runtime.entry_deadline_share", &p.entry_deadline_share, 0.0, 1.0,
        "the entry deadline is at least this share of the camera's frame interval (the median of "
        "the last 8 capture intervals), unless the frame waited for the later stages, so a stereo"
        " stage a little slower than the camera still gives depth for most frames; 0 = "
        "entry_deadline_ms alone; with entry_deadline_ms 0 there is no deadline at all");
  s.add("runtime.release_latency_ms", &p.release_latency_ms, 0.0, 1000.0,
        "hand every depth map on this long after its capture, a constant age; one ready later "
        "goes at once (overdue); held for at most about four frame intervals (longer: early, "
        "with a warning); 0 = as soon as it is ready");
  s.add("runtime.release_priority", &p.release_priority, 0, 99,
        "SCHED_FIFO priority of the thread that hands results on at their release time (and "
        "runs the result callback), where the process may use it; 0 = a normal thread");
  s.add("runtime.deterministic", &p.deterministic,
        "never drop frames (push waits): same output as the offline pipeline, for replays");
  s.add("runtime.backend", &p.backend, {"auto", "cpu", "cuda"},
        "where rectification, the sparse stereo stage, the contour stage's image passes and the "
        "densify solver run: auto = CUDA when a device works, else the CPU");
}

std::vector<int> parse_affinity(const std::string& text) {
  std::vector<int> cpus;
  std::string_view rest = text;
  while (!rest.empty()) {
    const std::size_t comma = rest.find(',');
    std::string_view item = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
    while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
    const bool digits =
        !item.empty() && item.size() <= 4 &&
        std::all_of(item.begin(), item.end(), [](char c) { return c >= '0' && c <= '9'; });
    if (!digits)
      throw Error("runtime.affinity: '" + std::string(item) + "' in \"" + text +
                  "\" is not a CPU number");
    const int cpu = std::stoi(std::string(item));
    if (cpu >= CPU_SETSIZE)
      throw Error("runtime.affinity: CPU " + std::to_string(cpu) + " is beyond the " +
                  std::to_string(CPU_SETSIZE) + " CPUs the system can address");
    if (std::find(cpus.begin(), cpus.end(), cpu) != cpus.end())
      throw Error("runtime.affinity: CPU " + std::to_string(cpu) + " is listed twice in \"" + text +
                  "\"");
    cpus.push_back(cpu);
    if (comma != std::string_view::npos && rest.empty())
      throw Error("runtime.affinity: \"" + text + "\" ends with a comma");
  }
  return cpus;
}

void validate(const RuntimeParams& p) {
  if (p.threads < 0 || p.threads > 3)
    throw Error("runtime.threads must be 0 (chosen by the usable CPUs), 1, 2 or 3, not " +
                std::to_string(p.threads));
  if (p.opencv_threads < 0 || p.opencv_threads > 256)
    throw Error("runtime.opencv_threads must be in [0, 256], not " +
                std::to_string(p.opencv_threads));
  if (p.queue_depth < 1 || p.queue_depth > 8)
    throw Error("runtime.queue_depth must be in [1, 8], not " + std::to_string(p.queue_depth));
  if (!(p.entry_deadline_ms >= 0 && p.entry_deadline_ms <= 1000))
    throw Error("runtime.entry_deadline_ms must be in [0, 1000], not " +
                std::to_string(p.entry_deadline_ms));
  if (!(p.entry_deadline_share >= 0 && p.entry_deadline_share <= 1))
    throw Error("runtime.entry_deadline_share must be in [0, 1], not " +
                std::to_string(p.entry_deadline_share));
  if (!(p.release_latency_ms >= 0 && p.release_latency_ms <= 1000))
    throw Error("runtime.release_latency_ms must be in [0, 1000], not " +
                std::to_string(p.release_latency_ms));
  if (p.release_priority < 0 || p.release_priority > 99)
    throw Error("runtime.release_priority must be in [0, 99], not " +
                std::to_string(p.release_priority));
  parse_affinity(p.affinity);
  if (p.backend != "auto" && p.backend != "cpu" && p.backend != "cuda")
    throw Error("runtime.backend must be auto, cpu or cuda, not '" + p.backend + "'");
}

int stage_threads(const RuntimeParams& p) {
  if (p.threads != 0) return p.threads;
  return usable_cpus() >= 4 ? 3 : 2;
}

}  // namespace dco::pipeline::runtime
