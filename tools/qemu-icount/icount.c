/* odoerr_icount: counts guest instructions executed (single vCPU), and writes the total to
 * the file named by the plugin argument out=PATH when the emulation ends.
 *   qemu-system-arm ... -plugin libodoerr_icount.so,out=count.txt -kernel app.elf
 * Optional: exclude=LO-HI (hexadecimal guest addresses): blocks that start in [LO, HI) are
 * not counted (a test seam's wait loop, whose length depends on the host's timing). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "qemu_plugin_min.h"

QEMU_PLUGIN_EXPORT int qemu_plugin_version = QEMU_PLUGIN_VERSION;

static uint64_t g_insns;
static uint64_t g_exclude_lo, g_exclude_hi;
static char g_out[512] = "icount.txt";
/* Optional profile (hist=PATH): instructions per translation block start address, for
 * guest code in the first 256 KiB (the firmware image); maps to symbols with nm. */
#define HIST_SLOTS (256 * 1024 / 2)
static uint64_t g_hist[HIST_SLOTS];
static char g_hist_path[512];

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb* tb) {
  (void)id;
  /* Every execution of this block adds its instruction count (inline, no callback). */
  const uint64_t n = qemu_plugin_tb_n_insns(tb);
  const uint64_t vaddr = qemu_plugin_tb_vaddr(tb);
  if (vaddr >= g_exclude_lo && vaddr < g_exclude_hi) return;
  qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &g_insns, n);
  const uint64_t slot = vaddr / 2;
  if (g_hist_path[0] != '\0' && slot < HIST_SLOTS) {
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &g_hist[slot], n);
  }
}

static void on_exit_cb(qemu_plugin_id_t id, void* userdata) {
  (void)id;
  (void)userdata;
  FILE* f = fopen(g_out, "w");
  if (f != NULL) {
    fprintf(f, "%llu\n", (unsigned long long)g_insns);
    fclose(f);
  }
  if (g_hist_path[0] != '\0') {
    FILE* h = fopen(g_hist_path, "w");
    if (h != NULL) {
      for (uint64_t i = 0; i < HIST_SLOTS; ++i) {
        if (g_hist[i] != 0) fprintf(h, "0x%llx %llu\n", (unsigned long long)(i * 2), (unsigned long long)g_hist[i]);
      }
      fclose(h);
    }
  }
}

QEMU_PLUGIN_EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t* info, int argc,
                                           char** argv) {
  (void)info;
  for (int i = 0; i < argc; ++i) {
    if (strncmp(argv[i], "out=", 4) == 0) {
      strncpy(g_out, argv[i] + 4, sizeof g_out - 1);
      g_out[sizeof g_out - 1] = '\0';
    }
    if (strncmp(argv[i], "exclude=", 8) == 0) {
      char* end = NULL;
      g_exclude_lo = strtoull(argv[i] + 8, &end, 16);
      g_exclude_hi = (end != NULL && *end == '-') ? strtoull(end + 1, NULL, 16) : 0;
      if (g_exclude_hi <= g_exclude_lo) {
        fprintf(stderr, "odoerr_icount: exclude=%s is not LO-HI with LO < HI\n", argv[i] + 8);
        return -1;
      }
    }
    if (strncmp(argv[i], "hist=", 5) == 0) {
      strncpy(g_hist_path, argv[i] + 5, sizeof g_hist_path - 1);
      g_hist_path[sizeof g_hist_path - 1] = '\0';
    }
  }
  qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
  qemu_plugin_register_atexit_cb(id, on_exit_cb, NULL);
  return 0;
}
