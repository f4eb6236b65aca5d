// The Morphing Crossbar's Verilog as a model library: Verilator compiles hdl/*.v into C++, and
// this driver clocks it in batches from C, so that a caller (morphing_crossbar.verilated, through
// ctypes) pays one call per batch of beats rather than one Python step per clock.
//
// The clock: inputs are set while clk is low and the design is evaluated (combinational
// settling), the handshakes of the cycle are read (valid & ready), then the rising edge
// commits them. Every output port is always ready (m_ready all ones): a node's fabric drains
// into its PBO's buffers.
#include <cstdint>

#include "Vmorphing_crossbar.h"
#include "verilated.h"

namespace {

template <typename T>
void put(T& signal, int lo, int width, uint64_t value) {
    const uint64_t mask = width >= 64 ? ~uint64_t(0) : (uint64_t(1) << width) - 1;
    const uint64_t old = uint64_t(signal);
    signal = T((old & ~(mask << lo)) | ((value & mask) << lo));
}

template <std::size_t W>
void put(VlWide<W>& signal, int lo, int width, uint64_t value) {
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

template <std::size_t W>
uint64_t get(const VlWide<W>& signal, int lo, int width) {
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
    int slots;
    int width;

    Model(int slots_, int width_) : slots(slots_), width(width_) {}

    void edge() {
        top.clk = 1;
        top.eval();
        top.clk = 0;
        ++cycles;
    }
};

}  // namespace

extern "C" {

void* mx_new(int slots, int width) {
    Model* model = new Model(slots, width);
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
    put(top.m_ready, 0, slots, ~uint64_t(0));
    top.eval();
    model->edge();
    model->cycles = 0;
    return model;
}

void mx_free(void* handle) { delete static_cast<Model*>(handle); }

uint64_t mx_cycles(void* handle) { return static_cast<Model*>(handle)->cycles; }

// Stream each port's beats (port p's are data[offsets[p]..offsets[p+1]) with their last flags)
// into the external inputs at once, and collect every output beat in the order it leaves
// (cycle, then port): out_port, out_data, out_last, at most `room` of them. Returns how many
// came out once `expected` did, or -1 when `limit` cycles passed first.
int64_t mx_stream(void* handle, const int64_t* offsets, const uint32_t* data, const uint8_t* last,
                  int64_t expected, int32_t* out_port, uint32_t* out_data, uint8_t* out_last,
                  int64_t room, uint64_t limit) {
    Model& model = *static_cast<Model*>(handle);
    Vmorphing_crossbar& top = model.top;
    const int n = model.slots;
    const int w = model.width;
    int64_t next[16];
    for (int p = 0; p < n; ++p) next[p] = offsets[p];
    int64_t out = 0;
    const uint64_t start = model.cycles;
    while (out < expected) {
        if (model.cycles - start >= limit) return -1;
        uint64_t valid = 0;
        for (int p = 0; p < n; ++p) {
            if (next[p] < offsets[p + 1]) {
                valid |= uint64_t(1) << p;
                put(top.s_data, p * w, w, data[next[p]]);
                put(top.s_last, p, 1, last[next[p]]);
            }
        }
        put(top.s_valid, 0, n, valid);
        top.eval();
        const uint64_t taken = get(top.s_valid, 0, n) & get(top.s_ready, 0, n);
        const uint64_t leaving = get(top.m_valid, 0, n);
        for (int p = 0; p < n; ++p) {
            if ((taken >> p) & 1) ++next[p];
            if ((leaving >> p) & 1 && out < room) {
                out_port[out] = p;
                out_data[out] = uint32_t(get(top.m_data, p * w, w));
                out_last[out] = uint8_t(get(top.m_last, p, 1));
                ++out;
            }
        }
        model.edge();
    }
    put(top.s_valid, 0, n, 0);
    top.eval();
    return out;
}

// Shift a partial bitstream's beats into `slot`'s wrapper, then wait for its verdict: the
// cycles from the first beat to the commit (code 0) or the refusal (the wrapper's error code),
// or -1 when `limit` cycles passed first.
int64_t mx_configure(void* handle, int slot, const uint32_t* beats, int64_t count, int32_t* code,
                     uint64_t limit) {
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
    return -1;
}

}  // extern "C"
