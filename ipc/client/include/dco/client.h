/* libdco-client: read the depth frames dcod publishes in its shared-memory ring.
 *
 * Plain C, stable ABI: every struct a caller passes starts with `struct_size`, set by the
 * matching *_init function. Options may gain fields at the end (older sizes are accepted); the
 * view, buffer and info structs are fixed for this soname. A client handle is not thread-safe;
 * use one per thread, and a view only with the handle that returned it. Frames are read-only
 * views into the mapping or copies into caller memory; neither path ever blocks the daemon.
 * No call is a cancellation point: a thread cancelled during one is cancelled at its next
 * cancellation point after the call returns (dco_client_wait_next within its timeout). */
#ifndef DCO_CLIENT_H
#define DCO_CLIENT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__)
#define DCO_CLIENT_API __attribute__((visibility("default")))
#else
#define DCO_CLIENT_API
#endif

typedef enum dco_status {
  DCO_OK = 0,
  DCO_E_INVALID_ARGUMENT = 1,  /* null pointer, bad struct_size, bad option */
  DCO_E_NO_SEGMENT = 2,        /* the segment file does not exist */
  DCO_E_IO = 3,                /* open, stat or mmap failed */
  DCO_E_BAD_FORMAT = 4,        /* not a depth ring, other version, inconsistent or truncated */
  DCO_E_PERMISSION = 5,        /* not readable by this user (readers need group dcod), wrong
                                  owner, world-writable, not a regular file */
  DCO_E_GEOMETRY = 6,          /* not the width/height the caller expects */
  DCO_E_NO_FRAME = 7,          /* nothing published yet */
  DCO_E_OVERTAKEN = 8,         /* the writer overwrote the slot (during every attempt) */
  DCO_E_TIMEOUT = 9,           /* no new frame within the timeout */
  DCO_E_WRITER_GONE = 10,      /* the writer stopped and no new ring replaced it */
  DCO_E_BUFFER_TOO_SMALL = 11, /* a copy destination is smaller than the frame */
  DCO_E_NOT_PUBLISHED = 12     /* the ring holds no such frame (other session, slot or index) */
} dco_status;

typedef struct dco_client dco_client;

typedef struct dco_client_options {
  uint32_t struct_size;
  const char* path;         /* segment file, e.g. /run/dcod/depth.shm */
  uint32_t expected_uid;    /* owner the file must have; default: the caller's uid */
  uint32_t expected_width;  /* 0 = any */
  uint32_t expected_height; /* 0 = any */
  uint32_t max_attempts;    /* reads of an overwritten slot before DCO_E_OVERTAKEN; default 8 */
  /* 0 (default): dco_client_wait_next sleeps until a frame is published. Above 0, it sleeps
   * until the writer starts filling a slot, then polls up to this many microseconds for that
   * frame: its CPU is awake when the frame lands instead of being woken then, at the cost of
   * polling through the writer's copy (about 0.5 ms for 1280x720 depth and image). Then it
   * sleeps again. At most 100000. The first polling wait of a thread also asks the kernel for a
   * 0.1 ms time slice for that thread, which it keeps (Linux 6.12+; policy and nice value
   * unchanged; real-time threads are left alone): polling readers sharing CPUs take turns sooner.
   */
  uint32_t poll_us;
} dco_client_options;

typedef struct dco_frame_info {
  uint32_t struct_size;
  uint32_t slot;
  uint64_t session_id;    /* changes when the daemon restarts */
  uint64_t publish_index; /* 1, 2, ... within a session */
  uint64_t frame_seq;     /* camera frame number */
  int64_t capture_ns;     /* CLOCK_MONOTONIC */
  int64_t publish_ns;     /* CLOCK_MONOTONIC */
  double fx, fy, cx, cy;  /* rectified left camera, pixels */
  double baseline_m;
  uint32_t width;
  uint32_t height;
  uint32_t image_channels; /* 0 when the ring carries no image */
  uint32_t reserved;
  size_t depth_stride; /* bytes between rows of the view */
  size_t image_stride;
} dco_frame_info;

/* A zero-copy frame: pointers into the read-only mapping. The pixels are only known to be one
 * consistent frame if dco_client_still_valid() says so after they were read; the pointers stay
 * mapped until the next call on the same client that returns a frame. */
typedef struct dco_frame_view {
  uint32_t struct_size;
  uint32_t reserved;
  dco_frame_info info;
  const float* depth;   /* metres, info.height rows of info.depth_stride bytes */
  const uint8_t* image; /* rectified left image, NULL without image */
  uint64_t token;       /* seqlock value the view was taken at */
} dco_frame_view;

/* Caller memory a frame is copied into. */
typedef struct dco_frame_buffer {
  uint32_t struct_size;
  uint32_t reserved;
  float* depth;
  size_t depth_stride; /* bytes; at least width * 4 */
  size_t depth_capacity;
  uint8_t* image; /* NULL: skip the image */
  size_t image_stride;
  size_t image_capacity;
} dco_frame_buffer;

DCO_CLIENT_API void dco_client_options_init(dco_client_options* options);
DCO_CLIENT_API void dco_frame_view_init(dco_frame_view* view);
DCO_CLIENT_API void dco_frame_buffer_init(dco_frame_buffer* buffer);
DCO_CLIENT_API void dco_frame_info_init(dco_frame_info* info);

/* Maps the segment read-only after checking its owner, mode and layout. */
DCO_CLIENT_API dco_status dco_client_open(const dco_client_options* options, dco_client** out);
/* Unmaps the ring: views it returned are gone with it. NULL is accepted; a handle must not be
 * closed twice or used after. */
DCO_CLIENT_API void dco_client_close(dco_client* client);

/* The newest frame as a view (only a view whose counter was even when taken is returned). It is
 * the newest there is, also after the writer stopped: DCO_OK does not say the daemon runs
 * (dco_client_wait_next says DCO_E_WRITER_GONE). A restarted daemon's ring this client refuses
 * (another size, format or owner) is said by every call while it is at the path. */
DCO_CLIENT_API dco_status dco_client_latest(dco_client* client, dco_frame_view* view);
/* 1 while the slot behind the view has not been rewritten, else 0; 0 as well for a view another
 * handle returned (its pixels go with that handle). */
DCO_CLIENT_API int dco_client_still_valid(const dco_client* client, const dco_frame_view* view);
/* Waits up to timeout_ms for a frame newer than the last one this client returned. Remaps when
 * the daemon restarted (new session id). DCO_E_WRITER_GONE as soon as the writer is seen to
 * have stopped or died; calling again picks up a daemon that comes back, and while none does,
 * each later call waits out its timeout and says DCO_E_WRITER_GONE again (a loop that calls
 * again does not spin). A restarted daemon's ring this client refuses is said the same way: at
 * once, then at the end of each wait while it stays. timeout_ms 0 looks once; a negative one is
 * DCO_E_INVALID_ARGUMENT. */
DCO_CLIENT_API dco_status dco_client_wait_next(dco_client* client, int32_t timeout_ms,
                                               dco_frame_view* view);
/* Copies the frame a view names; DCO_E_OVERTAKEN when its slot changed before or during the
 * copy, or the view is of a ring a restarted daemon left; DCO_E_INVALID_ARGUMENT for a view no
 * call returned a frame into. dst->image NULL skips the image.
 * dst is written in place: after any status but DCO_OK it may hold part of a newer frame, so a
 * caller that keeps drawing its last good frame while reads fail copies into another buffer
 * than the one that frame is in (two buffers in turn). */
DCO_CLIENT_API dco_status dco_client_copy(const dco_client* client, const dco_frame_view* view,
                                          dco_frame_buffer* dst);
/* Copies the newest frame, retrying overwritten slots; succeeds only with an untorn copy. info
 * may be NULL. dst as for dco_client_copy: after a failure it may hold a torn frame. */
DCO_CLIENT_API dco_status dco_client_read_latest(dco_client* client, dco_frame_buffer* dst,
                                                 dco_frame_info* info);
/* The frame an announcement names (the fields of an LCM DCO_DEPTH descriptor, or any other
 * wake-up), accepted only when slot `slot` of the ring really holds publish index `publish_index`
 * of session `session_id`, read consistently under the slot's seqlock. The announcement is
 * trusted for nothing else: metadata and pixels come from the slot, so a forged one cannot make
 * the caller accept depth the daemon did not write. DCO_E_NOT_PUBLISHED when the ring cannot have
 * held that frame in that slot (other session, slot out of range, index 0, not yet published, or
 * an older index in the slot), DCO_E_OVERTAKEN when the slot holds a newer frame or is being
 * rewritten (the announced one is gone, if it was ever there). An announcement of a session other
 * than the mapped one first follows a restarted daemon to its new ring. */
DCO_CLIENT_API dco_status dco_client_view_announced(dco_client* client, uint64_t session_id,
                                                    uint32_t slot, uint64_t publish_index,
                                                    dco_frame_view* view);
/* dco_client_view_announced, then dco_client_copy: succeeds only with an untorn copy of exactly
 * the announced frame. info may be NULL. dst as for dco_client_copy. */
DCO_CLIENT_API dco_status dco_client_read_announced(dco_client* client, uint64_t session_id,
                                                    uint32_t slot, uint64_t publish_index,
                                                    dco_frame_buffer* dst, dco_frame_info* info);
/* Session of the mapped ring. */
DCO_CLIENT_API uint64_t dco_client_session_id(const dco_client* client);

DCO_CLIENT_API const char* dco_client_strerror(dco_status status);
/* Details of the last failure on the calling thread (empty when there was none), valid until
 * that thread's next call into the library. */
DCO_CLIENT_API const char* dco_client_last_error(void);

#ifdef __cplusplus
}
#endif

#endif /* DCO_CLIENT_H */
