/* A qemu-user TCG plugin: counts the guest instructions each guest thread executes and attributes them to the
 * stages that qsg_app brackets with marker system calls (firmware_app/runtime/stage_marker.h, --stage-markers).
 * Counting is deterministic: every translated block adds its instruction count when it starts executing, so a run
 * of the same binary on the same input counts the same instructions whatever the host's load.
 *
 *   qemu-aarch64 -plugin build/arm_insn/insn_count_plugin.so,out=RUNS.txt BINARY ARGS...
 *
 * RUNS.txt gets one line per marked run, "run STAGE SEQUENCE INSTRUCTIONS VCPU", then at exit "vcpu V
 * INSTRUCTIONS" per guest thread slot, "total INSTRUCTIONS" and "unmatched N" (end markers without their begin).
 * Nested runs count inclusively (the backend's update includes its door pass), as the CPU-time budgets do.
 *
 * Written against the plugin API that QEMU documents (docs/devel/tcg-plugins.rst, include/qemu/qemu-plugin.h);
 * Debian ships qemu-user with plugin support but not the header, so the few declarations used are below.
 * Build: cc -O2 -shared -fPIC -o insn_count_plugin.so insn_count_plugin.c -lpthread */
#include <inttypes.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- The QEMU plugin API (version 1: QEMU 6.0 to 7.2) ---- */
typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t; /* not read */
struct qemu_plugin_tb;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void* userdata);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void* userdata);
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb* tb);
typedef void (*qemu_plugin_vcpu_syscall_cb_t)(qemu_plugin_id_t id, unsigned int vcpu_index, int64_t num, uint64_t a1,
                                              uint64_t a2, uint64_t a3, uint64_t a4, uint64_t a5, uint64_t a6,
                                              uint64_t a7, uint64_t a8);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_tb_exec_cb(struct qemu_plugin_tb* tb, qemu_plugin_vcpu_udata_cb_t cb,
                                          enum qemu_plugin_cb_flags flags, void* userdata);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb* tb);
void qemu_plugin_register_vcpu_syscall_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_syscall_cb_t cb);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void* userdata);
void qemu_plugin_outs(const char* string);

#define EXPORT __attribute__((visibility("default")))
EXPORT int qemu_plugin_version = 1;

/* ---- The marker protocol: firmware_app/runtime/stage_marker.h ---- */
#define MARKER_SYSCALL 0x5153
#define MARKER_MAGIC 0x7173672d73746167ULL
#define MARKER_BEGIN 1
#define MARKER_END 2

/* qemu-user gives each live guest thread its own vCPU index (a freed index is reused by the next thread). Each slot
 * is written only by its own thread, so no lock is needed on the counting path. */
#define MAX_VCPUS 256
#define MAX_DEPTH 8

struct open_run {
  uint64_t stage, sequence, start;
};

struct vcpu {
  uint64_t insns;
  int depth;
  struct open_run open[MAX_DEPTH];
  char pad[64]; /* keeps two threads' counters off one cache line */
};

static struct vcpu g_vcpus[MAX_VCPUS];
static uint64_t g_beyond; /* instructions of vCPUs past MAX_VCPUS (atomic) */
static uint64_t g_unmatched;
static FILE* g_out;
static pthread_mutex_t g_out_mutex = PTHREAD_MUTEX_INITIALIZER;

static void on_tb_exec(unsigned int vcpu_index, void* n_insns) {
  const uint64_t n = (uint64_t)(uintptr_t)n_insns;
  if (vcpu_index < MAX_VCPUS) g_vcpus[vcpu_index].insns += n;
  else __atomic_fetch_add(&g_beyond, n, __ATOMIC_RELAXED);
}

static void on_tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb* tb) {
  (void)id;
  qemu_plugin_register_vcpu_tb_exec_cb(tb, on_tb_exec, QEMU_PLUGIN_CB_NO_REGS,
                                       (void*)(uintptr_t)qemu_plugin_tb_n_insns(tb));
}

static void on_syscall(qemu_plugin_id_t id, unsigned int vcpu_index, int64_t num, uint64_t a1, uint64_t a2,
                       uint64_t a3, uint64_t a4, uint64_t a5, uint64_t a6, uint64_t a7, uint64_t a8) {
  (void)id, (void)a5, (void)a6, (void)a7, (void)a8;
  if (num != MARKER_SYSCALL || a1 != MARKER_MAGIC || vcpu_index >= MAX_VCPUS) return;
  struct vcpu* v = &g_vcpus[vcpu_index];
  if (a2 == MARKER_BEGIN) {
    if (v->depth < MAX_DEPTH) v->open[v->depth] = (struct open_run){a3, a4, v->insns};
    ++v->depth; /* deeper than MAX_DEPTH: counted, so the matching ends stay paired */
    return;
  }
  if (a2 != MARKER_END) return;
  /* The innermost open run of this stage; anything opened inside it and never closed is dropped with it. */
  int d = v->depth < MAX_DEPTH ? v->depth : MAX_DEPTH;
  while (d > 0 && v->open[d - 1].stage != a3) --d;
  if (d == 0) {
    __atomic_fetch_add(&g_unmatched, 1, __ATOMIC_RELAXED);
    return;
  }
  const struct open_run r = v->open[d - 1];
  v->depth = d - 1;
  pthread_mutex_lock(&g_out_mutex);
  if (g_out != NULL)
    fprintf(g_out, "run %" PRIu64 " %" PRIu64 " %" PRIu64 " %u\n", r.stage, r.sequence, v->insns - r.start,
            vcpu_index);
  pthread_mutex_unlock(&g_out_mutex);
}

static void on_plugin_exit(qemu_plugin_id_t id, void* userdata) {
  (void)id, (void)userdata;
  uint64_t total = g_beyond;
  pthread_mutex_lock(&g_out_mutex);
  for (unsigned i = 0; i < MAX_VCPUS; ++i) {
    total += g_vcpus[i].insns;
    if (g_out != NULL && g_vcpus[i].insns > 0) fprintf(g_out, "vcpu %u %" PRIu64 "\n", i, g_vcpus[i].insns);
  }
  char line[128];
  snprintf(line, sizeof line, "insn_count: %" PRIu64 " guest instructions, %" PRIu64 " unmatched markers\n", total,
           g_unmatched);
  qemu_plugin_outs(line);
  if (g_out != NULL) {
    fprintf(g_out, "total %" PRIu64 "\nunmatched %" PRIu64 "\n", total, g_unmatched);
    fclose(g_out);
    g_out = NULL;
  }
  pthread_mutex_unlock(&g_out_mutex);
}

EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t* info, int argc, char** argv) {
  (void)info;
  const char* out_path = NULL;
  for (int i = 0; i < argc; ++i) {
    if (strncmp(argv[i], "out=", 4) == 0) {
      out_path = argv[i] + 4;
    } else {
      fprintf(stderr, "insn_count: unknown argument '%s' (out=FILE)\n", argv[i]);
      return 1;
    }
  }
  if (out_path != NULL) {
    g_out = fopen(out_path, "w");
    if (g_out == NULL) {
      fprintf(stderr, "insn_count: cannot write '%s'\n", out_path);
      return 1;
    }
  }
  qemu_plugin_register_vcpu_tb_trans_cb(id, on_tb_trans);
  qemu_plugin_register_vcpu_syscall_cb(id, on_syscall);
  qemu_plugin_register_atexit_cb(id, on_plugin_exit, NULL);
  return 0;
}
