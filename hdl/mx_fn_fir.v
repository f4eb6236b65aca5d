// mx_fn_fir: a four-tap FIR functionality, y[n] = (c0 x[n] + c1 x[n-1] + c2 x[n-2] + c3 x[n-3])
// >> SHIFT, modulo 2^DATA_W.
//
// TAPS packs four unsigned 4-bit coefficients, c0 in the low nibble. The history holds the last
// three accepted inputs; `clear` (the wrapper's commit) zeroes it, so a route that has just been
// switched onto this FIR does not see samples of the stream it carried before.
`default_nettype none

module mx_fn_fir #(
    parameter DATA_W = 8,           // payload bits per beat
    parameter [15:0] TAPS = 16'h1331, // c3..c0, four bits each
    parameter [15:0] SHIFT = 3      // right shift of the sum (low four bits used)
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
    localparam SUM_W = DATA_W + 6;  // four products of DATA_W + 4 bits

    reg [DATA_W-1:0] x1_reg;
    reg [DATA_W-1:0] x2_reg;
    reg [DATA_W-1:0] x3_reg;

    wire [SUM_W-1:0] sum = in_data * TAPS[3:0] + x1_reg * TAPS[7:4]
                         + x2_reg * TAPS[11:8] + x3_reg * TAPS[15:12];
    // The high bits wrap away by design (results are modulo 2^DATA_W).
    /* verilator lint_off UNUSEDSIGNAL */
    wire [SUM_W-1:0] shifted = sum >> SHIFT[3:0];
    /* verilator lint_on UNUSEDSIGNAL */

    always @(posedge clk) begin
        if (rst || clear) begin
            x1_reg <= {DATA_W{1'b0}};
            x2_reg <= {DATA_W{1'b0}};
            x3_reg <= {DATA_W{1'b0}};
        end else if (in_valid && in_ready) begin
            x1_reg <= in_data;
            x2_reg <= x1_reg;
            x3_reg <= x2_reg;
        end
    end

    mx_pipe #(.DATA_W(DATA_W)) pipe (
        .clk(clk), .rst(rst), .clear(clear),
        .in_valid(in_valid), .in_ready(in_ready), .in_data(shifted[DATA_W-1:0]),
        .in_last(in_last),
        .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data), .out_last(out_last),
        .empty(empty)
    );
endmodule

`default_nettype wire
