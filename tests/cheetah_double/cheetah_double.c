/*
 * A test double of Total Phase's Cheetah library (cheetah.so) with one
 * adapter on SynTouch's multi-BioTac board: 1 to 3 BioTacs that answer
 * sampling commands and the serial-number read as the BioTac Product
 * Manual describes, with deterministic contents, timed as a 4.4 MHz SPI
 * bus would be. Written for tactile_force's tests; it exports the c_ch_*
 * names Total Phase's shared object exports, for the functions the
 * backend calls.
 *
 * Contents: at each E1 command the frame counter k steps; the sample at
 * position p (0-based, commands since the last E1) of the BioTac at board
 * position s is double_value(s, k mod 4096, p), except TDC, which answers
 * k mod 4096 (so a reader can tell k). tests/cheetah_double/mod.rs has
 * the same function.
 *
 * The BioTacs on the board (CHEETAH_DOUBLE_ELECTRODES=n / "electrodes"):
 * 19 electrodes (BioTacs, the default) or 24 (BioTac SPs). A sampling
 * command for an electrode the sensor lacks (E20..E24 on a BioTac) is
 * answered with SynTouch's error word "channel not recognized" (0xA558).
 * Every sampling command is checked against the sensor's default sequence
 * (E1, PAC, ..., En, PAC, PDC, PAC, TAC, PAC, TDC, PAC: 44 words, or 54
 * on the SP); the stat "out_of_order" counts those that differ.
 *
 * Faults (environment at load, or cheetah_double_control at run time):
 *   CHEETAH_DOUBLE_PARITY_EVERY=n  / "parity_every": every n-th response
 *       word gets one data bit flipped (a parity error); 0 = none.
 *   CHEETAH_DOUBLE_MISSING=mask    / "missing": board positions with no
 *       BioTac (MISO reads 0xFF).
 *   "plugged" 0/1: the adapter unplugged (every call on an open handle
 *       fails, none is found) or plugged back (handles opened before
 *       stay dead, as after a USB re-enumeration).
 *   CHEETAH_DOUBLE_SERIAL=n: the adapter's unique id (default 1364000042).
 * Counters (cheetah_double_stat): "words", "parity_injected", "frames",
 *   "opens", "submits", "out_of_order".
 */
#include <errno.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define CH_OK 0
#define CH_UNABLE_TO_OPEN (-8)
#define CH_INVALID_HANDLE (-10)
#define CH_COMMUNICATION_ERROR (-7)
#define CH_SPI_BATCH_EMPTY_QUEUE (-101)
#define CH_SPI_ASYNC_EMPTY (-103)
#define CH_SPI_ASYNC_MAX_REACHED (-105)
#define PORT_NOT_FREE 0x8000

#define MAX_OPS 65536
#define MAX_ASYNC 16

enum op_kind { OP_SS, OP_BYTE, OP_DELAY };
struct op { int kind; int value; };

static struct op queue_ops[MAX_OPS];
static int queue_len;
static int64_t async_due[MAX_ASYNC];
static int async_head, async_count;
static int64_t last_due;

static int plugged = 1;
static int generation = 1;
static int open_handle; /* 0: closed */
static int bitrate_khz = 1000;
static long parity_every, missing_mask;
static long electrodes = 19;
static uint32_t unique_id = 1364000042u;
static int inited;

static long stat_words, stat_parity, stat_frames, stat_opens, stat_submits, stat_order;

/* Per board position: what the next bytes clocked under its own SS give. */
static uint8_t out_buf[3][32];
static int out_len[3], out_pos[3];
static uint32_t frame_k;
static int slot_in_frame;

static int64_t now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (int64_t)t.tv_sec * 1000000000LL + t.tv_nsec;
}

static void sleep_until(int64_t due)
{
    for (;;) {
        int64_t left = due - now_ns();
        if (left <= 0)
            return;
        struct timespec t = { left / 1000000000LL, left % 1000000000LL };
        if (nanosleep(&t, NULL) == 0)
            return;
    }
}

static void init(void)
{
    if (inited)
        return;
    inited = 1;
    const char *v;
    if ((v = getenv("CHEETAH_DOUBLE_PARITY_EVERY")))
        parity_every = strtol(v, NULL, 10);
    if ((v = getenv("CHEETAH_DOUBLE_MISSING")))
        missing_mask = strtol(v, NULL, 0);
    if ((v = getenv("CHEETAH_DOUBLE_ELECTRODES")))
        electrodes = strtol(v, NULL, 10);
    if ((v = getenv("CHEETAH_DOUBLE_SERIAL")))
        unique_id = (uint32_t)strtoul(v, NULL, 10);
}

uint16_t double_value(uint32_t s, uint32_t k, uint32_t p)
{
    uint32_t h = (s + 1) * 0x9E3779B1u ^ k * 0x85EBCA77u ^ p * 0xC2B2AE3Du;
    h ^= h >> 15;
    h *= 0x2C1B3C6Du;
    h ^= h >> 12;
    return (uint16_t)(h & 0xFFF);
}

static uint8_t odd(uint8_t b)
{
    return (uint8_t)(b | (__builtin_popcount(b) % 2 == 0));
}

static uint16_t word_of(uint16_t v)
{
    uint8_t hi = odd((uint8_t)((v >> 5) << 1));
    uint8_t lo = odd((uint8_t)((v & 0x1F) << 3));
    return (uint16_t)(hi << 8 | lo);
}

static int handle_ok(int h)
{
    if (!plugged)
        return CH_COMMUNICATION_ERROR;
    if (h <= 0 || h != open_handle)
        return CH_INVALID_HANDLE;
    return CH_OK;
}

/* The channel index the default sequence samples at position p. */
static int expected_index(int p)
{
    int i = p / 2;
    if (p % 2)
        return 0; /* PAC */
    if (i < electrodes)
        return 17 + i;
    return 1 + (i - (int)electrodes); /* PDC 1, TAC 2, TDC 3 */
}

/* The bytes of one slave-select segment have all been clocked. */
static void end_segment(int mask, const uint8_t *mosi, int n)
{
    if (n < 1 || mask == 0)
        return;
    uint8_t cmd = mosi[0];
    if ((cmd & 0x80) && n >= 2) {
        int index = (cmd >> 1) & 0x3F;
        if (index == 17) {
            frame_k = (frame_k + 1) & 0xFFF;
            slot_in_frame = 0;
            stat_frames++;
        }
        if (index != expected_index(slot_in_frame) || slot_in_frame >= 2 * (electrodes + 3))
            stat_order++;
        int lacks = index > 16 + electrodes; /* an electrode past the sensor's */
        for (int s = 0; s < 3; s++) {
            if (!(mask & (1 << s)))
                continue;
            uint16_t v = index == 3 ? (uint16_t)frame_k
                                    : double_value((uint32_t)s, frame_k, (uint32_t)slot_in_frame);
            uint16_t w = lacks ? 0xA558 : word_of(v);
            stat_words++;
            if (!lacks && parity_every > 0 && stat_words % parity_every == 0) {
                w ^= 0x0008; /* a data bit of the low byte */
                stat_parity++;
            }
            out_buf[s][0] = (uint8_t)(w >> 8);
            out_buf[s][1] = (uint8_t)w;
            out_len[s] = 2;
            out_pos[s] = 0;
        }
        slot_in_frame++;
    } else if (cmd == 0x61 && n >= 2 && mosi[1] == 0x15) {
        for (int s = 0; s < 3; s++) {
            if (!(mask & (1 << s)))
                continue;
            char serial[17];
            memcpy(serial, "BTSIM0000000000", 15); /* 15 characters and the position: 16 */
            serial[15] = (char)('0' + s);
            serial[16] = 0;
            memcpy(out_buf[s], serial, 16);
            out_len[s] = 16;
            out_pos[s] = 0;
        }
    }
}

/* Runs the queue: fills data_in (up to n bytes), returns bytes shifted.
 * A segment whose first byte is 0 reads the selected BioTac's pending
 * answer; any other segment is a command (MISO 0). */
static int run_queue(uint8_t *data_in, int n)
{
    int mask = 0, count = 0, seg_n = 0, reading = 0;
    uint8_t seg[64];
    for (int i = 0; i < queue_len; i++) {
        struct op o = queue_ops[i];
        if (o.kind == OP_SS) {
            end_segment(mask, seg, seg_n);
            mask = o.value & 7;
            seg_n = 0;
        } else if (o.kind == OP_BYTE) {
            if (seg_n == 0)
                reading = o.value == 0;
            uint8_t miso = 0x00;
            int s = mask == 1 ? 0 : mask == 2 ? 1 : mask == 4 ? 2 : -1;
            if (s >= 0 && (missing_mask & mask))
                miso = 0xFF;
            else if (s >= 0 && reading && out_pos[s] < out_len[s])
                miso = out_buf[s][out_pos[s]++];
            if (seg_n < (int)sizeof seg)
                seg[seg_n++] = (uint8_t)o.value;
            if (data_in && count < n)
                data_in[count] = miso;
            count++;
        }
    }
    end_segment(mask, seg, seg_n);
    return count;
}

/* Time the queue takes on the bus (ns): bytes and SS changes at the
 * bitrate (8 bit times each), the delays, and 3 us of adapter overhead per
 * sampling command (a segment starting with a byte with bit 7 set). */
static int64_t queue_ns(void)
{
    double bit_ns = 1e6 / bitrate_khz;
    double t = 0;
    int seg_start = 1;
    for (int i = 0; i < queue_len; i++) {
        struct op o = queue_ops[i];
        if (o.kind == OP_SS) {
            t += 8 * bit_ns;
            seg_start = 1;
        } else if (o.kind == OP_BYTE) {
            t += 8 * bit_ns;
            if (seg_start && (o.value & 0x80))
                t += 3000;
            seg_start = 0;
        } else {
            t += o.value;
        }
    }
    return (int64_t)(t + 0.5);
}

int c_ch_find_devices_ext(int num_devices, uint16_t *devices, int num_ids, uint32_t *ids)
{
    init();
    if (!plugged)
        return 0;
    if (num_devices > 0 && devices)
        devices[0] = (uint16_t)(open_handle ? PORT_NOT_FREE : 0);
    if (num_ids > 0 && ids)
        ids[0] = unique_id;
    return 1;
}

int c_ch_open(int port)
{
    init();
    if (!plugged || port != 0 || open_handle)
        return CH_UNABLE_TO_OPEN;
    open_handle = generation * 16 + 1;
    queue_len = 0;
    async_count = 0;
    last_due = 0;
    stat_opens++;
    return open_handle;
}

int c_ch_close(int h)
{
    if (h > 0 && h == open_handle)
        open_handle = 0;
    return CH_OK;
}

const char *c_ch_status_string(int status)
{
    switch (status) {
    case CH_OK: return "CH_OK";
    case CH_UNABLE_TO_OPEN: return "CH_UNABLE_TO_OPEN";
    case CH_INVALID_HANDLE: return "CH_INVALID_HANDLE";
    case CH_COMMUNICATION_ERROR: return "CH_COMMUNICATION_ERROR";
    case CH_SPI_BATCH_EMPTY_QUEUE: return "CH_SPI_BATCH_EMPTY_QUEUE";
    case CH_SPI_ASYNC_EMPTY: return "CH_SPI_ASYNC_EMPTY";
    case CH_SPI_ASYNC_MAX_REACHED: return "CH_SPI_ASYNC_MAX_REACHED";
    default: return 0;
    }
}

int c_ch_target_power(int h, uint8_t flag)
{
    (void)flag;
    return handle_ok(h);
}

int c_ch_spi_configure(int h, int polarity, int phase, int bitorder, uint8_t ss_polarity)
{
    (void)polarity; (void)phase; (void)bitorder; (void)ss_polarity;
    return handle_ok(h);
}

int c_ch_spi_bitrate(int h, int khz)
{
    int r = handle_ok(h);
    if (r < 0)
        return r;
    bitrate_khz = khz > 0 ? khz : 1000;
    return bitrate_khz;
}

int c_ch_spi_queue_clear(int h)
{
    int r = handle_ok(h);
    if (r == CH_OK)
        queue_len = 0;
    return r;
}

int c_ch_spi_queue_oe(int h, uint8_t oe)
{
    (void)oe;
    return handle_ok(h);
}

static int push(int kind, int value)
{
    if (queue_len >= MAX_OPS)
        return CH_COMMUNICATION_ERROR;
    queue_ops[queue_len].kind = kind;
    queue_ops[queue_len].value = value;
    queue_len++;
    return CH_OK;
}

int c_ch_spi_queue_ss(int h, uint8_t active)
{
    int r = handle_ok(h);
    return r < 0 ? r : push(OP_SS, active);
}

int c_ch_spi_queue_array(int h, int n, const uint8_t *data)
{
    int r = handle_ok(h);
    if (r < 0)
        return r;
    for (int i = 0; i < n; i++)
        if ((r = push(OP_BYTE, data[i])) < 0)
            return r;
    return n;
}

int c_ch_spi_queue_delay_ns(int h, int ns)
{
    int r = handle_ok(h);
    if (r < 0)
        return r;
    r = push(OP_DELAY, ns);
    return r < 0 ? r : ns;
}

int c_ch_spi_batch_shift(int h, int n, uint8_t *data_in)
{
    int r = handle_ok(h);
    if (r < 0)
        return r;
    if (queue_len == 0)
        return CH_SPI_BATCH_EMPTY_QUEUE;
    int64_t due = now_ns() + queue_ns();
    int count = run_queue(data_in, n);
    sleep_until(due);
    return count;
}

int c_ch_spi_async_submit(int h)
{
    int r = handle_ok(h);
    if (r < 0)
        return r;
    if (queue_len == 0)
        return CH_SPI_BATCH_EMPTY_QUEUE;
    if (async_count >= MAX_ASYNC)
        return CH_SPI_ASYNC_MAX_REACHED;
    int64_t start = now_ns() > last_due ? now_ns() : last_due;
    last_due = start + queue_ns();
    async_due[(async_head + async_count) % MAX_ASYNC] = last_due;
    async_count++;
    stat_submits++;
    return CH_OK;
}

int c_ch_spi_async_collect(int h, int n, uint8_t *data_in)
{
    int r = handle_ok(h);
    if (r < 0)
        return r;
    if (async_count == 0)
        return CH_SPI_ASYNC_EMPTY;
    int64_t due = async_due[async_head];
    async_head = (async_head + 1) % MAX_ASYNC;
    async_count--;
    sleep_until(due);
    if ((r = handle_ok(h)) < 0)
        return r;
    return run_queue(data_in, n);
}

/* Fault injection: returns 0, or -1 for an unknown key. */
int cheetah_double_control(const char *key, long value)
{
    init();
    if (!strcmp(key, "plugged")) {
        if (!value && plugged) {
            /* The device is gone: its handle dies, pending batches too. */
            generation++;
            open_handle = 0;
            async_count = 0;
        }
        plugged = value != 0;
    } else if (!strcmp(key, "parity_every")) {
        parity_every = value;
    } else if (!strcmp(key, "missing")) {
        missing_mask = value;
    } else if (!strcmp(key, "electrodes")) {
        electrodes = value;
    } else {
        return -1;
    }
    return 0;
}

long cheetah_double_stat(const char *key)
{
    if (!strcmp(key, "words")) return stat_words;
    if (!strcmp(key, "parity_injected")) return stat_parity;
    if (!strcmp(key, "frames")) return stat_frames;
    if (!strcmp(key, "opens")) return stat_opens;
    if (!strcmp(key, "submits")) return stat_submits;
    if (!strcmp(key, "out_of_order")) return stat_order;
    return -1;
}

uint32_t ch_c_version(void)
{
    return 0x03060306u; /* v3.06, needs header >= v3.06 */
}
