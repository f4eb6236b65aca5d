// mx_fn_pass: the pass-through functionality, y = x.
//
// A placeholder component in a pipeline: a slot that only carries data keeps the same buffering
// (and so the same latency) as the slots that compute.
`default_nettype none

module mx_fn_pass #(
    parameter DATA_W = 8  // payload bits per beat
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
    mx_pipe #(.DATA_W(DATA_W)) pipe (
        .clk(clk), .rst(rst), .clear(clear),
        .in_valid(in_valid), .in_ready(in_ready), .in_data(in_data), .in_last(in_last),
        .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data), .out_last(out_last),
        .empty(empty)
    );
endmodule

`default_nettype wire
