#pragma once

#include <string>
#include <vector>

namespace dco {
class ConfigSchema;
}

namespace dco::pipeline::runtime {

// How the real-time runtime runs the stages ("runtime.*").
struct RuntimeParams {
  // Stage threads: 1 = one worker runs every stage; 2 = stereo | contour + densify;
  // 3 = stereo | contour | densify; 0 = chosen by the usable CPUs (stage_threads).
  int threads = 0;
  // CPUs the stage threads are pinned to, e.g. "0,1": thread i runs on the (i mod n)-th entry;
  // empty = wherever the scheduler puts them.
  std::string affinity;
  // Threads of OpenCV's own parallel loops (DIS optical flow) while the runtime runs
  // (OpenCvThreadsLease: process-wide, put back when it stops): 0 = auto, 1 when the stage
  // threads are as many as the usable CPUs (OpenCV's pool would only take turns with them), else
  // OpenCV's choice.
  int opencv_threads = 0;
  // Frames each queue between two stage threads holds. Every queued frame is a frame of latency.
  int queue_depth = 1;
  // A frame that waited at the entry longer than its deadline gets no depth of its own: its grey
  // image still serves its neighbours' flow, and the stereo stage waits for the next frame
  // instead. Every depth map then starts within the deadline of its entry, so the latency does
  // not depend on when the stage happened to be free. The deadline is this (ms) or
  // entry_deadline_share of the camera's frame interval, whichever is longer. 0 = no deadline:
  // hold the newest frame however long.
  double entry_deadline_ms = 2;
  // The deadline's share of the frame interval (the median of the last capture intervals). A
  // frame that waited less than this share for the stereo stage's own work is still worth its
  // depth: the next one would come later than the wait saved. One that waited longer than
  // entry_deadline_ms for the later stages (the stereo thread waiting for a slot or room in the
  // queue) is late all the same (late_at_entry). A stereo stage a little slower than the camera
  // then gives depth for most frames, not for every second one, and the depth a renderer holds
  // is no older (bench/RESULTS.md). 0 = entry_deadline_ms alone.
  double entry_deadline_share = 0.4;
  // Hand each depth map to the result callback this long (ms) after its capture, however early it
  // is ready, so a renderer gets depth (and the passthrough image it belongs to) at a constant
  // age. A map ready later than that goes out at once and counts as overdue. 0 = as soon as it
  // is ready. Deterministic runs ignore it.
  double release_latency_ms = 0;
  // With release_latency_ms: the SCHED_FIFO priority (1-99) the release thread asks for, so it
  // wakes at each release time even while the stage threads keep every CPU busy (a normal thread
  // woken then can wait up to a scheduler tick or more). The result callback runs at it too. A
  // process without CAP_SYS_NICE or a high enough RLIMIT_RTPRIO gets a normal thread with a
  // 0.1 ms time slice instead (RuntimeStats::release_realtime says which). 0 = never ask.
  int release_priority = 1;
  // Never drop: push waits for room, so every frame is processed in order and the output equals
  // the offline DepthPipeline's (for replays and tests).
  bool deterministic = false;
  // Where the stages run: "cuda" (a CUDA device), "cpu", or "auto" (CUDA when a device works,
  // else the CPU). Resolved by the program that builds the runtime (dco::gpu::choose_backend).
  std::string backend = "auto";
};

void register_params(ConfigSchema& schema, RuntimeParams& params);
void validate(const RuntimeParams& params);  // throws dco::Error

// runtime.threads as it will run: an explicit count as it is; 0 gives 3 where at least four CPUs
// are usable, else 2. With the stages on a GPU the stereo thread mostly waits while optical flow
// and the densify system run on the CPU; on the CPU path four to eight CPUs ran a 1280x720 frame
// 9-27 % faster with contour and densify on threads of their own, and with two threads four
// CPUs did not keep up with a 30 fps camera (bench/RESULTS.md).
int stage_threads(const RuntimeParams& params);

// Parses runtime.affinity ("0,2,3"); throws dco::Error naming the bad entry.
std::vector<int> parse_affinity(const std::string& text);

}  // namespace dco::pipeline::runtime
