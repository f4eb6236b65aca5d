// mx_fn_gain: the gain/offset functionality, y = ((x * GAIN) >> 4) + OFFSET, modulo 2^DATA_W.
//
// GAIN is unsigned fixed point with four fraction bits (16 means 1.0), so a gain below one
// (attenuation) needs no divider. The result wraps like the Python model's.
`default_nettype none

module mx_fn_gain #(
    parameter DATA_W = 8,         // payload bits per beat
    parameter [15:0] GAIN = 16,   // unsigned, four fraction bits
    parameter [15:0] OFFSET = 0   // added after scaling
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              clear,
    input  wire              in_valid,
    output wire              in_ready,
    input  wire [DATA_W-1:0] in_data,
    input  wire              in_last,
    output wire              out_valid,
    input  wire              out_ready,
    output wire [DATA_W-1:0] out_data,
    output wire              out_last,
    output wire              empty
);
    wire [DATA_W+15:0] product = in_data * GAIN;
    // The high bits wrap away by design (results are modulo 2^DATA_W).
    /* verilator lint_off UNUSEDSIGNAL */
    wire [DATA_W+15:0] scaled  = (product >> 4) + {{DATA_W{1'b0}}, OFFSET};
    /* verilator lint_on UNUSEDSIGNAL */

    mx_pipe #(.DATA_W(DATA_W)) pipe (
        .clk(clk), .rst(rst), .clear(clear),
        .in_valid(in_valid), .in_ready(in_ready), .in_data(scaled[DATA_W-1:0]), .in_last(in_last),
        .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data), .out_last(out_last),
        .empty(empty)
    );
endmodule

`default_nettype wire
