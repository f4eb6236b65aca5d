// full_crossbar: the comparison design with a full point-to-point crossbar.
//
// Same slots as morphing_crossbar (mx_wrapper + mx_functionality), but every selector can pick
// any of the 2N streams: the N external inputs and the N functionality outputs. The sources of
// slot i are 0 none, 1 + k input k, 1 + N + k functionality k. This is the "fast but large" end
// of the design space the Morphing Crossbar sits in; benchmarks/crossbar.py synthesizes both.
`default_nettype none

module full_crossbar #(
    parameter N = 4,                                  // slots (2..16)
    parameter DATA_W = 8,                             // payload bits per beat
    parameter CFG_W = 1,                              // configuration port bits a beat
    parameter [4*N-1:0]  FUNC_KIND = {N{4'd0}},       // slot i's library functionality
    parameter [16*N-1:0] FUNC_P0 = {N{16'd0}},        // slot i's first coefficient
    parameter [16*N-1:0] FUNC_P1 = {N{16'd0}}         // slot i's second coefficient
) (
    input  wire                clk,
    input  wire                rst,
    input  wire [N-1:0]        s_valid,
    output wire [N-1:0]        s_ready,
    input  wire [N*DATA_W-1:0] s_data,
    input  wire [N-1:0]        s_last,
    output wire [N-1:0]        m_valid,
    input  wire [N-1:0]        m_ready,
    output wire [N*DATA_W-1:0] m_data,
    output wire [N-1:0]        m_last,
    input  wire                cfg_valid,
    input  wire [3:0]          cfg_slot,
    input  wire [CFG_W-1:0]    cfg_data,
    input  wire                cfg_last,
    output wire                cfg_done,
    output wire                cfg_error,
    output wire [2:0]          cfg_error_code,
    output wire [N-1:0]        slot_busy
);
    localparam NSRC = 1 + 2 * N;
    localparam SEL_W = $clog2(NSRC);

    wire [N-1:0]        f_valid;
    wire [N-1:0]        f_ready;
    wire [N*DATA_W-1:0] f_data;
    wire [N-1:0]        f_last;
    // the same source vector for every slot
    wire [NSRC-1:0]        src_valid = {f_valid, s_valid, 1'b0};
    wire [NSRC*DATA_W-1:0] src_data = {f_data, s_data, {DATA_W{1'b0}}};
    wire [NSRC-1:0]        src_last = {f_last, s_last, 1'b0};
    wire [N*NSRC-1:0]      w_src_ready;
    wire [N-1:0]           w_commit;
    wire [N-1:0]           w_error;
    wire [N*3-1:0]         w_error_code;

    genvar i, k;
    generate
        for (i = 0; i < N; i = i + 1) begin : g_slot
            wire              fn_in_valid;
            wire              fn_in_ready;
            wire [DATA_W-1:0] fn_in_data;
            wire              fn_in_last;
            wire              fn_empty;
            wire              fn_clear;

            mx_wrapper #(
                .SLOT_ID(i), .DATA_W(DATA_W), .NSRC(NSRC), .SEL_W(SEL_W), .CFG_W(CFG_W),
                .SELF_SRC(1 + N + i), .RESET_FSEL(1 + i), .RESET_OSEL(1 + N + i)
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

        // Ready of each stream: the OR over every slot of its ready towards that source.
        for (k = 1; k < NSRC; k = k + 1) begin : g_ready
            wire [N-1:0] takers;
            for (i = 0; i < N; i = i + 1) begin : g_taker
                assign takers[i] = w_src_ready[i*NSRC + k];
            end
            if (k <= N) begin : g_input
                assign s_ready[k-1] = |takers;
            end else begin : g_function
                assign f_ready[k-1-N] = |takers;
            end
        end
    endgenerate

    assign cfg_done = |w_commit;
    assign cfg_error = |w_error;
    mx_error_mux #(.N(N)) error_mux (
        .error(w_error), .codes(w_error_code), .code(cfg_error_code)
    );
endmodule

`default_nettype wire
