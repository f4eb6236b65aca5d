// morphing_crossbar: N slots on a hybrid interconnect, the Morphing Bus mirrored inside the FPGA
// (section 5.2 of the paper).
//
// Each slot is a wrapper (mx_wrapper: routing state and reconfiguration control) plus a
// functionality (mx_functionality: fixed data processing). Each slot has an external stream
// input s_* and output m_* (a board position on the Morphing Bus). A wrapper's two selectors
// choose among NSRC = 3 + 2 * LOCAL sources:
//   0              none
//   1              the slot's own external input
//   2              the ring: the functionality output of slot (i - 1) mod N, the circular
//                  routing of the Morphing Bus
//   3 + k          the local crossbar: the functionality output of slot k of the slot's cluster
//                  (clusters are LOCAL consecutive slots)
//   3 + LOCAL + k  the local crossbar: the external input of slot k of the slot's cluster, so a
//                  board plugged into any port of the cluster reaches the same internal modules
// so pipelines compose along the ring and, inside a cluster, point to point. Every source is
// meant for at most one consumer (the Python configuration checks it); each source's ready is
// the OR of the consumers selecting it. Functionality inputs have registered ready
// (mx_pipe), so no routing can close a combinational loop.
//
// After reset slot i routes s_i -> functionality i -> m_i. A partial bitstream for slot i enters
// through the configuration port with cfg_slot = i (morphing_crossbar/bitstream.py packs it).
`default_nettype none

module morphing_crossbar #(
    parameter N = 4,                                  // slots (2..16)
    parameter DATA_W = 8,                             // payload bits per beat
    parameter CFG_W = 1,                              // configuration port bits a beat
    parameter LOCAL = (N < 4) ? N : 4,                // slots per local-crossbar cluster
    parameter [4*N-1:0]  FUNC_KIND = {N{4'd0}},       // slot i's library functionality
    parameter [16*N-1:0] FUNC_P0 = {N{16'd0}},        // slot i's first coefficient
    parameter [16*N-1:0] FUNC_P1 = {N{16'd0}}         // slot i's second coefficient
) (
    input  wire                clk,
    input  wire                rst,
    // external stream inputs, one per slot
    input  wire [N-1:0]        s_valid,
    output wire [N-1:0]        s_ready,
    input  wire [N*DATA_W-1:0] s_data,
    input  wire [N-1:0]        s_last,
    // external stream outputs, one per slot
    output wire [N-1:0]        m_valid,
    input  wire [N-1:0]        m_ready,
    output wire [N*DATA_W-1:0] m_data,
    output wire [N-1:0]        m_last,
    // configuration port (partial bitstreams)
    input  wire                cfg_valid,
    input  wire [3:0]          cfg_slot,
    input  wire [CFG_W-1:0]    cfg_data,
    input  wire                cfg_last,
    output wire                cfg_done,        // pulse: a frame was committed
    output wire                cfg_error,       // pulse: a frame was refused
    output wire [2:0]          cfg_error_code,  // why, valid with cfg_error
    output wire [N-1:0]        slot_busy        // slot i is being reconfigured
);
    localparam NSRC = 3 + 2 * LOCAL;
    localparam INPUTS = 3 + LOCAL;                     // selector of the cluster's first input
    localparam SEL_W = 4;

    // functionality outputs, consumed through the ring and the local crossbar
    wire [N-1:0]        f_valid;
    wire [N-1:0]        f_ready;
    wire [N*DATA_W-1:0] f_data;
    wire [N-1:0]        f_last;
    // every wrapper's ready towards each of its sources
    wire [N*NSRC-1:0]   w_src_ready;
    wire [N-1:0]        w_commit;
    wire [N-1:0]        w_error;
    wire [N*3-1:0]      w_error_code;

    genvar i, k;
    generate
        if (N < 2 || N > 16 || LOCAL < 1 || N % LOCAL != 0 || NSRC > 16) begin : g_check
            mx_error_n_2_to_16_and_local_dividing_n bad ();
        end

        for (i = 0; i < N; i = i + 1) begin : g_slot
            localparam CLUSTER = (i / LOCAL) * LOCAL;
            localparam RING = (i + N - 1) % N;

            wire [NSRC-1:0]        src_valid;
            wire [NSRC*DATA_W-1:0] src_data;
            wire [NSRC-1:0]        src_last;
            wire                   fn_in_valid;
            wire                   fn_in_ready;
            wire [DATA_W-1:0]      fn_in_data;
            wire                   fn_in_last;
            wire                   fn_empty;
            wire                   fn_clear;

            assign src_valid[2:0] = {f_valid[RING], s_valid[i], 1'b0};
            assign src_data[3*DATA_W-1:0] =
                {f_data[RING*DATA_W +: DATA_W], s_data[i*DATA_W +: DATA_W], {DATA_W{1'b0}}};
            assign src_last[2:0] = {f_last[RING], s_last[i], 1'b0};
            assign src_valid[INPUTS-1:3] = f_valid[CLUSTER +: LOCAL];
            assign src_data[INPUTS*DATA_W-1:3*DATA_W] = f_data[CLUSTER*DATA_W +: LOCAL*DATA_W];
            assign src_last[INPUTS-1:3] = f_last[CLUSTER +: LOCAL];
            assign src_valid[NSRC-1:INPUTS] = s_valid[CLUSTER +: LOCAL];
            assign src_data[NSRC*DATA_W-1:INPUTS*DATA_W] = s_data[CLUSTER*DATA_W +: LOCAL*DATA_W];
            assign src_last[NSRC-1:INPUTS] = s_last[CLUSTER +: LOCAL];

            mx_wrapper #(
                .SLOT_ID(i), .DATA_W(DATA_W), .NSRC(NSRC), .SEL_W(SEL_W), .CFG_W(CFG_W),
                .SELF_SRC(3 + i - CLUSTER), .RESET_FSEL(1), .RESET_OSEL(3 + i - CLUSTER)
            ) wrapper (
                .clk(clk), .rst(rst),
                .cfg_valid(cfg_valid && cfg_slot == i), .cfg_data(cfg_data), .cfg_last(cfg_last),
                .cfg_commit(w_commit[i]), .cfg_error(w_error[i]),
                .cfg_error_code(w_error_code[i*3 +: 3]), .busy(slot_busy[i]),
                .src_valid(src_valid), .src_ready(w_src_ready[i*NSRC +: NSRC]),
                .src_data(src_data), .src_last(src_last),
                .fn_in_valid(fn_in_valid), .fn_in_ready(fn_in_ready), .fn_in_data(fn_in_data),
                .fn_in_last(fn_in_last), .fn_empty(fn_empty), .fn_clear(fn_clear),
                .out_valid(m_valid[i]), .out_ready(m_ready[i]),
                .out_data(m_data[i*DATA_W +: DATA_W]), .out_last(m_last[i])
            );

            mx_functionality #(
                .DATA_W(DATA_W), .KIND(FUNC_KIND[4*i +: 4]),
                .P0(FUNC_P0[16*i +: 16]), .P1(FUNC_P1[16*i +: 16])
            ) functionality (
                .clk(clk), .rst(rst), .clear(fn_clear),
                .in_valid(fn_in_valid), .in_ready(fn_in_ready), .in_data(fn_in_data),
                .in_last(fn_in_last),
                .out_valid(f_valid[i]), .out_ready(f_ready[i]),
                .out_data(f_data[i*DATA_W +: DATA_W]), .out_last(f_last[i]),
                .empty(fn_empty)
            );
        end

        // Ready of functionality k: its ring successor or any slot of its cluster selects it;
        // ready of external input k: its own slot or any slot of its cluster selects it.
        for (k = 0; k < N; k = k + 1) begin : g_ready
            localparam CLUSTER = (k / LOCAL) * LOCAL;
            localparam NEXT = (k + 1) % N;
            wire [LOCAL-1:0] local_f_ready;
            wire [LOCAL-1:0] local_s_ready;
            for (i = 0; i < LOCAL; i = i + 1) begin : g_local
                assign local_f_ready[i] = w_src_ready[(CLUSTER + i)*NSRC + 3 + (k - CLUSTER)];
                assign local_s_ready[i] =
                    w_src_ready[(CLUSTER + i)*NSRC + INPUTS + (k - CLUSTER)];
            end
            assign f_ready[k] = w_src_ready[NEXT*NSRC + 2] || (|local_f_ready);
            assign s_ready[k] = w_src_ready[k*NSRC + 1] || (|local_s_ready);
        end
    endgenerate

    assign cfg_done = |w_commit;
    assign cfg_error = |w_error;
    mx_error_mux #(.N(N)) error_mux (
        .error(w_error), .codes(w_error_code), .code(cfg_error_code)
    );
endmodule

`default_nettype wire
