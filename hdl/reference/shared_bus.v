// shared_bus: the comparison design with one shared, time-multiplexed bus.
//
// Same slots as morphing_crossbar, but all 2N streams (producers: input k = k, functionality k
// = N + k) share one data bus. A round-robin arbiter grants one routed, valid producer per
// cycle; the consumers (functionality inputs, output ports) whose selector names it take the
// beat. Selectors use the full crossbar's encoding (0 none, 1 + producer). This is the "small
// but slow" end of the design space: one beat per cycle for the whole fabric.
`default_nettype none

module shared_bus #(
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
    localparam P = 2 * N;              // producers
    localparam SEL_W = $clog2(P + 1);
    localparam G_W = $clog2(P);

    wire [N-1:0]        f_valid;
    wire [N-1:0]        f_ready;
    wire [N*DATA_W-1:0] f_data;
    wire [N-1:0]        f_last;
    wire [P-1:0]        p_valid = {f_valid, s_valid};
    wire [P*DATA_W-1:0] p_data = {f_data, s_data};
    wire [P-1:0]        p_last = {f_last, s_last};

    // consumers: c < N is functionality c's input, c >= N is output port c - N
    wire [P*SEL_W-1:0] c_sel;
    wire [P-1:0]       c_ready;
    wire [N-1:0]       isolate;
    wire [N-1:0]       fn_clear;
    wire [N-1:0]       fn_empty;
    wire [N-1:0]       fn_in_ready;
    wire [N-1:0]       w_commit;
    wire [N-1:0]       w_error;
    wire [N*3-1:0]     w_error_code;

    wire           granted;
    wire [G_W-1:0] grant;
    wire [P-1:0]   routed;
    wire [P-1:0]   takes;
    wire           take = |takes;

    wire [DATA_W-1:0] bus_data = p_data[grant*DATA_W +: DATA_W];
    wire              bus_last = p_last[grant];

    rr_arbiter #(.M(P)) arbiter (
        .clk(clk), .rst(rst), .request(p_valid & routed), .advance(granted && take),
        .granted(granted), .grant(grant)
    );

    genvar i, c, p;
    generate
        for (c = 0; c < P; c = c + 1) begin : g_consumer
            assign takes[c] = (c_sel[c*SEL_W +: SEL_W] == {1'b0, grant} + 1'b1) && c_ready[c];
        end
        for (p = 0; p < P; p = p + 1) begin : g_producer
            wire [P-1:0] selects;
            for (c = 0; c < P; c = c + 1) begin : g_sel
                assign selects[c] = (c_sel[c*SEL_W +: SEL_W] == p + 1);
            end
            assign routed[p] = |selects;
            if (p < N) begin : g_input
                assign s_ready[p] = granted && grant == p && take;
            end else begin : g_function
                assign f_ready[p-N] = granted && grant == p && take;
            end
        end

        for (i = 0; i < N; i = i + 1) begin : g_slot
            wire [SEL_W-1:0] fsel = c_sel[i*SEL_W +: SEL_W];
            wire [SEL_W-1:0] osel = c_sel[(N+i)*SEL_W +: SEL_W];
            wire             fn_in_valid = granted && fsel == {1'b0, grant} + 1'b1 && !isolate[i];

            assign c_ready[i] = fn_in_ready[i] && !isolate[i];
            assign c_ready[N+i] = m_ready[i];
            assign m_valid[i] = granted && osel == {1'b0, grant} + 1'b1;
            assign m_data[i*DATA_W +: DATA_W] = bus_data;
            assign m_last[i] = bus_last;
            assign slot_busy[i] = isolate[i];

            mx_slot_config #(
                .SLOT_ID(i), .NSRC(P + 1), .SEL_W(SEL_W), .CFG_W(CFG_W), .SELF_SRC(1 + N + i),
                .RESET_FSEL(1 + i), .RESET_OSEL(1 + N + i)
            ) config_unit (
                .clk(clk), .rst(rst),
                .cfg_valid(cfg_valid && cfg_slot == i), .cfg_data(cfg_data), .cfg_last(cfg_last),
                .drained(fn_empty[i]),
                .fsel(c_sel[i*SEL_W +: SEL_W]), .osel(c_sel[(N+i)*SEL_W +: SEL_W]),
                .isolate(isolate[i]), .clear(fn_clear[i]), .commit(w_commit[i]),
                .error(w_error[i]), .error_code(w_error_code[i*3 +: 3])
            );

            mx_functionality #(
                .DATA_W(DATA_W), .KIND(FUNC_KIND[4*i +: 4]),
                .P0(FUNC_P0[16*i +: 16]), .P1(FUNC_P1[16*i +: 16])
            ) functionality (
                .clk(clk), .rst(rst), .clear(fn_clear[i]),
                .in_valid(fn_in_valid), .in_ready(fn_in_ready[i]), .in_data(bus_data),
                .in_last(bus_last),
                .out_valid(f_valid[i]), .out_ready(f_ready[i]),
                .out_data(f_data[i*DATA_W +: DATA_W]), .out_last(f_last[i]),
                .empty(fn_empty[i])
            );
        end
    endgenerate

    assign cfg_done = |w_commit;
    assign cfg_error = |w_error;
    mx_error_mux #(.N(N)) error_mux (
        .error(w_error), .codes(w_error_code), .code(cfg_error_code)
    );
endmodule

`default_nettype wire
