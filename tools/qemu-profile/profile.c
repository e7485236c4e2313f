/*
 * A QEMU TCG plugin that counts the guest instructions each translation block executes,
 * in epochs: every time the guest enters the function at `marker=ADDR` (the bench
 * firmware's `hstdout_fmt`, one call per line it prints), the counts since the last
 * entry are written out as one epoch. `symbols.py` maps them to functions.
 *
 * Output (QPROF_OUT, default qemu-profile.out): lines `EPOCH VADDR INSNS EXECUTIONS`.
 * The plugin API of QEMU 7.2 (Debian 12's qemu-system-arm, QEMU_PLUGIN_VERSION 1) is
 * declared here, the handful of calls used, so that no QEMU source tree is needed.
 */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
struct qemu_plugin_tb;
typedef struct {
    const char *target_name;
    int min, cur;
    bool system_emulation;
} qemu_info_t;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS };
typedef void (*tb_trans_cb)(qemu_plugin_id_t, struct qemu_plugin_tb *);
typedef void (*udata_cb)(qemu_plugin_id_t, void *);
typedef void (*vcpu_udata_cb)(unsigned int, void *);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, tb_trans_cb cb);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *tb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op,
                                              void *ptr, uint64_t imm);
void qemu_plugin_register_vcpu_tb_exec_cb(struct qemu_plugin_tb *tb, vcpu_udata_cb cb,
                                          enum qemu_plugin_cb_flags flags, void *userdata);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, udata_cb cb, void *userdata);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

/* One translation of a block: its start, its size, how often it ran (and at the last dump). */
struct block {
    uint64_t vaddr, insns, count, dumped;
    struct block *next;
};
static struct block *blocks;
static uint64_t marker;
static FILE *out;
static int epoch;

static void dump(void) {
    for (struct block *b = blocks; b; b = b->next)
        if (b->count != b->dumped) {
            fprintf(out, "%d %lx %lu %lu\n", epoch, (unsigned long)b->vaddr,
                    (unsigned long)b->insns, (unsigned long)(b->count - b->dumped));
            b->dumped = b->count;
        }
    epoch++;
}

static void on_marker(unsigned int cpu, void *udata) { dump(); }

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb *tb) {
    struct block *b = calloc(1, sizeof *b);
    if (!b)
        abort();
    b->vaddr = qemu_plugin_tb_vaddr(tb);
    b->insns = qemu_plugin_tb_n_insns(tb);
    b->next = blocks;
    blocks = b;
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &b->count, 1);
    /* Thumb addresses: the symbol has bit 0 set, the block's address not. */
    if (marker && (b->vaddr | 1) == (marker | 1))
        qemu_plugin_register_vcpu_tb_exec_cb(tb, on_marker, QEMU_PLUGIN_CB_NO_REGS, NULL);
}

static void on_qemu_exit(qemu_plugin_id_t id, void *udata) {
    dump();
    fclose(out);
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id,
                                                               const qemu_info_t *info, int argc,
                                                               char **argv) {
    for (int i = 0; i < argc; i++)
        if (!strncmp(argv[i], "marker=", 7))
            marker = strtoull(argv[i] + 7, NULL, 16);
    const char *path = getenv("QPROF_OUT");
    out = fopen(path ? path : "qemu-profile.out", "w");
    if (!out)
        return -1;
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
    qemu_plugin_register_atexit_cb(id, on_qemu_exit, NULL);
    return 0;
}
