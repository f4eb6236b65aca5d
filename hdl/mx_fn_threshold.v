// mx_fn_threshold: the threshold functionality (a noise gate), y = x if x >= LEVEL else 0.
`default_nettype none

module mx_fn_threshold #(
    parameter DATA_W = 8,        // payload bits per beat
    parameter [15:0] LEVEL = 0   // smallest value that passes
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
    wire passes;
    generate
        if (LEVEL == 16'd0) begin : g_open
            assign passes = 1'b1;  // every value passes a zero level
        end else begin : g_compare
            assign passes = ({{16{1'b0}}, in_data} >= {{DATA_W{1'b0}}, LEVEL});
        end
    endgenerate
    wire [DATA_W-1:0] gated = passes ? in_data : {DATA_W{1'b0}};

    mx_pipe #(.DATA_W(DATA_W)) pipe (
        .clk(clk), .rst(rst), .clear(clear),
        .in_valid(in_valid), .in_ready(in_ready), .in_data(gated), .in_last(in_last),
        .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data), .out_last(out_last),
        .empty(empty)
    );
endmodule

`default_nettype wire
