// The Morphing Crossbar's Verilog as a model library: Verilator compiles hdl/*.v into C++, and
// this driver clocks it from C, so that a caller (morphing_crossbar.verilated, through ctypes)
// pays one call per batch of beats (or per beat, the node's loop) rather than one Python step
// per clock.
//
// The clock: inputs are set while clk is low and the design is evaluated (combinational
// settling), the handshakes of the cycle are read (valid & ready), then the rising edge
// commits them. Every output port is always ready (m_ready all ones): a node's fabric drains
// into its PBO's buffers.
//
// The fabric's shape is compiled in (MX_SLOTS, MX_DATA_W, MX_CFG_W, and MX_FABRIC, a digest of
// all its parameters: morphing_crossbar.verilated.build passes them with -D), so a library can
// only drive the design it was built with, and mx_fabric tells the caller which one that is.
// Only the mx_* functions are exported (the library is built with -fvisibility=hidden).
#include <cstdint>

#include "Vmorphing_crossbar.h"
#include "verilated.h"

#if !defined(MX_SLOTS) || !defined(MX_DATA_W) || !defined(MX_CFG_W) || !defined(MX_FABRIC)
#error "build with -DMX_SLOTS=N -DMX_DATA_W=W -DMX_CFG_W=C -DMX_FABRIC=digest (build.py does)"
#endif

static_assert(MX_SLOTS >= 2 && MX_SLOTS <= 16, "the crossbar has 2..16 slots");
static_assert(MX_DATA_W >= 1 && MX_DATA_W <= 32, "a beat is 1..32 bits (uint32_t)");
static_assert(sizeof(Vmorphing_crossbar::s_data) * 8 >= MX_SLOTS * MX_DATA_W &&
                  sizeof(Vmorphing_crossbar::m_data) * 8 >= MX_SLOTS * MX_DATA_W &&
                  sizeof(Vmorphing_crossbar::s_valid) * 8 >= MX_SLOTS,
              "the verilated ports are narrower than MX_SLOTS x MX_DATA_W: another fabric's RTL");

#define MX_EXPORT extern "C" __attribute__((visibility("default")))

namespace {

constexpr int N = MX_SLOTS;
constexpr int W = MX_DATA_W;
constexpr int64_t STALLED = -1;   // the limit of cycles passed first
constexpr int64_t UNEXPECTED = -2;  // a beat left where the caller expects none (or no more)

template <typename T>
void put(T& signal, int lo, int width, uint64_t value) {
    const uint64_t mask = width >= 64 ? ~uint64_t(0) : (uint64_t(1) << width) - 1;
    const uint64_t old = uint64_t(signal);
    signal = T((old & ~(mask << lo)) | ((value & mask) << lo));
}

template <std::size_t Words>
void put(VlWide<Words>& signal, int lo, int width, uint64_t value) {
    for (int bit = 0; bit < width; ++bit) {
        const int at = lo + bit;
        const uint32_t one = uint32_t(1) << (at % 32);
        if ((value >> bit) & 1) {
            signal[at / 32] |= one;
        } else {
            signal[at / 32] &= ~one;
        }
    }
}

template <typename T>
uint64_t get(const T& signal, int lo, int width) {
    const uint64_t mask = width >= 64 ? ~uint64_t(0) : (uint64_t(1) << width) - 1;
    return (uint64_t(signal) >> lo) & mask;
}

template <std::size_t Words>
uint64_t get(const VlWide<Words>& signal, int lo, int width) {
    uint64_t value = 0;
    for (int bit = 0; bit < width; ++bit) {
        const int at = lo + bit;
        value |= uint64_t((signal[at / 32] >> (at % 32)) & 1) << bit;
    }
    return value;
}

struct Model {
    VerilatedContext context;
    Vmorphing_crossbar top{&context};
    uint64_t cycles = 0;

    void edge() {
        top.clk = 1;
        top.eval();
        top.clk = 0;
        ++cycles;
    }

    // Withdraw every input beat: a call that gives up must not leave one offered to the next.
    void idle_inputs() {
        put(top.s_valid, 0, N, 0);
        top.eval();
    }

    void idle_configuration() {
        top.cfg_valid = 0;
        top.cfg_last = 0;
        top.eval();
    }
};

}  // namespace

// What the library was built for: slots, data width, configuration width, parameter digest.
MX_EXPORT void mx_fabric(uint64_t* shape) {
    shape[0] = MX_SLOTS;
    shape[1] = MX_DATA_W;
    shape[2] = MX_CFG_W;
    shape[3] = MX_FABRIC;
}

MX_EXPORT void* mx_new() {
    Model* model = new Model();
    Vmorphing_crossbar& top = model->top;
    top.clk = 0;
    top.rst = 1;
    top.s_valid = 0;
    top.m_ready = 0;
    top.cfg_valid = 0;
    top.cfg_last = 0;
    for (int i = 0; i < 4; ++i) {
        top.eval();
        model->edge();
    }
    top.rst = 0;
    put(top.m_ready, 0, N, ~uint64_t(0));
    top.eval();
    model->edge();
    model->cycles = 0;
    return model;
}

MX_EXPORT void mx_free(void* handle) { delete static_cast<Model*>(handle); }

MX_EXPORT uint64_t mx_cycles(void* handle) { return static_cast<Model*>(handle)->cycles; }

// Stream each input port's beats (port p's are data[offsets[p]..offsets[p+1]), the last one
// marked last) into the external inputs at once, and collect each output port's beats in the
// order they leave: output q's into out_data[out_offsets[q]..out_offsets[q+1]), the room the
// routing gives it. Returns how many came out (offsets[N]), -1 when `limit` cycles passed first,
// -2 when a beat left at an output with no room left (the RTL and the routing disagree).
MX_EXPORT int64_t mx_stream(void* handle, const int64_t* offsets, const uint32_t* data,
                            const int64_t* out_offsets, uint32_t* out_data, uint64_t limit) {
    Model& model = *static_cast<Model*>(handle);
    Vmorphing_crossbar& top = model.top;
    int64_t next[N];
    int64_t out_next[N];
    for (int p = 0; p < N; ++p) {
        next[p] = offsets[p];
        out_next[p] = out_offsets[p];
    }
    const int64_t expected = offsets[N];
    int64_t out = 0;
    const uint64_t start = model.cycles;
    while (out < expected) {
        if (model.cycles - start >= limit) {
            model.idle_inputs();
            return STALLED;
        }
        uint64_t valid = 0;
        for (int p = 0; p < N; ++p) {
            if (next[p] < offsets[p + 1]) {
                valid |= uint64_t(1) << p;
                put(top.s_data, p * W, W, data[next[p]]);
                put(top.s_last, p, 1, next[p] == offsets[p + 1] - 1);
            }
        }
        put(top.s_valid, 0, N, valid);
        top.eval();
        const uint64_t taken = get(top.s_valid, 0, N) & get(top.s_ready, 0, N);
        const uint64_t leaving = get(top.m_valid, 0, N);
        for (int p = 0; p < N; ++p) {
            if ((taken >> p) & 1) ++next[p];
            if ((leaving >> p) & 1) {
                if (out_next[p] >= out_offsets[p + 1]) {
                    model.idle_inputs();
                    return UNEXPECTED;
                }
                out_data[out_next[p]++] = uint32_t(get(top.m_data, p * W, W));
                ++out;
            }
        }
        model.edge();
    }
    model.idle_inputs();
    return out;
}

// One beat (marked last) into input `port`, expected at output `output`: mx_stream for the
// node's loop, which sends one sample a cycle, without its arrays. Returns the beat's data, or
// -1 or -2 as mx_stream does (-2 also for a port outside the fabric).
MX_EXPORT int64_t mx_beat(void* handle, int port, uint32_t data, int output, uint64_t limit) {
    if (port < 0 || port >= N || output < 0 || output >= N) return UNEXPECTED;
    int64_t in_offsets[N + 1];
    int64_t out_offsets[N + 1];
    for (int p = 0; p <= N; ++p) {
        in_offsets[p] = p > port;
        out_offsets[p] = p > output;
    }
    uint32_t out = 0;
    const int64_t got = mx_stream(handle, in_offsets, &data, out_offsets, &out, limit);
    return got < 0 ? got : int64_t(out);
}

// Shift a partial bitstream's beats into `slot`'s wrapper, then wait for its verdict: the
// cycles from the first beat to the commit (code 0) or the refusal (the wrapper's error code),
// -1 when `limit` cycles passed first, -2 for a slot outside the fabric.
MX_EXPORT int64_t mx_configure(void* handle, int slot, const uint32_t* beats, int64_t count,
                               int32_t* code, uint64_t limit) {
    if (slot < 0 || slot >= N) return UNEXPECTED;
    Model& model = *static_cast<Model*>(handle);
    Vmorphing_crossbar& top = model.top;
    const uint64_t start = model.cycles;
    int64_t sent = 0;
    while (model.cycles - start < limit) {
        if (sent < count) {
            top.cfg_valid = 1;
            top.cfg_slot = slot;
            top.cfg_data = beats[sent];
            top.cfg_last = sent == count - 1;
        } else {
            top.cfg_valid = 0;
            top.cfg_last = 0;
        }
        top.eval();
        if (sent >= count && (top.cfg_done || top.cfg_error)) {
            *code = top.cfg_done ? 0 : top.cfg_error_code;
            return int64_t(model.cycles - start);
        }
        model.edge();
        if (sent < count) ++sent;
    }
    model.idle_configuration();
    return STALLED;
}
