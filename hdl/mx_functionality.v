// mx_functionality: the functionality half of a slot, chosen from the library by KIND.
//
// The functionality is the static, data-processing part of a hardware component (section 5.2 of
// the paper): it is built once with the fabric and never touched by partial reconfiguration.
// KIND: 0 pass-through, 1 gain/offset (P0 gain, P1 offset), 2 threshold (P0 level),
// 3 four-tap FIR (P0 taps, P1 shift), 4 3x3 median over frames of rows (P0 row width),
// 5 contrast stretch of 8-bit frames (P0 clip in permille, P1 minimum spread), 6 running median
// of five signed samples. See morphing_crossbar/functions.py for the same arithmetic, and
// docs/crossbar.md for how to add one.
`default_nettype none

module mx_functionality #(
    parameter DATA_W = 8,       // payload bits per beat
    parameter [3:0]  KIND = 0,  // which library functionality
    parameter [15:0] P0 = 0,    // first coefficient (meaning depends on KIND)
    parameter [15:0] P1 = 0     // second coefficient (meaning depends on KIND)
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
    generate
        if (KIND == 4'd0) begin : g_pass
            mx_fn_pass #(.DATA_W(DATA_W)) fn (
                .clk(clk), .rst(rst), .clear(clear),
                .in_valid(in_valid), .in_ready(in_ready), .in_data(in_data), .in_last(in_last),
                .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data),
                .out_last(out_last), .empty(empty)
            );
        end else if (KIND == 4'd1) begin : g_gain
            mx_fn_gain #(.DATA_W(DATA_W), .GAIN(P0), .OFFSET(P1)) fn (
                .clk(clk), .rst(rst), .clear(clear),
                .in_valid(in_valid), .in_ready(in_ready), .in_data(in_data), .in_last(in_last),
                .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data),
                .out_last(out_last), .empty(empty)
            );
        end else if (KIND == 4'd2) begin : g_threshold
            mx_fn_threshold #(.DATA_W(DATA_W), .LEVEL(P0)) fn (
                .clk(clk), .rst(rst), .clear(clear),
                .in_valid(in_valid), .in_ready(in_ready), .in_data(in_data), .in_last(in_last),
                .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data),
                .out_last(out_last), .empty(empty)
            );
        end else if (KIND == 4'd3) begin : g_fir
            mx_fn_fir #(.DATA_W(DATA_W), .TAPS(P0), .SHIFT(P1)) fn (
                .clk(clk), .rst(rst), .clear(clear),
                .in_valid(in_valid), .in_ready(in_ready), .in_data(in_data), .in_last(in_last),
                .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data),
                .out_last(out_last), .empty(empty)
            );
        end else if (KIND == 4'd4) begin : g_median3x3
            mx_fn_median3x3 #(.DATA_W(DATA_W), .WIDTH(P0)) fn (
                .clk(clk), .rst(rst), .clear(clear),
                .in_valid(in_valid), .in_ready(in_ready), .in_data(in_data), .in_last(in_last),
                .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data),
                .out_last(out_last), .empty(empty)
            );
        end else if (KIND == 4'd5) begin : g_stretch
            mx_fn_stretch #(.DATA_W(DATA_W), .CLIP(P0), .MIN_SPREAD(P1)) fn (
                .clk(clk), .rst(rst), .clear(clear),
                .in_valid(in_valid), .in_ready(in_ready), .in_data(in_data), .in_last(in_last),
                .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data),
                .out_last(out_last), .empty(empty)
            );
        end else if (KIND == 4'd6) begin : g_median5
            mx_fn_median5 #(.DATA_W(DATA_W)) fn (
                .clk(clk), .rst(rst), .clear(clear),
                .in_valid(in_valid), .in_ready(in_ready), .in_data(in_data), .in_last(in_last),
                .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data),
                .out_last(out_last), .empty(empty)
            );
        end else begin : g_bad_kind
            // Elaboration-time check: an unknown KIND names a module that does not exist.
            mx_error_kind_not_in_library bad ();
        end
    endgenerate
endmodule

`default_nettype wire
