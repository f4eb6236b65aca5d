// mx_sort3: three values sorted (unsigned), as {high, middle, low}: three compare-exchanges.
//
// mx_fn_median3x3 sorts each column of its window once, when the column comes in, so the median
// of the nine pixels needs only the sorted columns (mx_median9).
`default_nettype none

module mx_sort3 #(
    parameter DATA_W = 8  // bits of a value
) (
    input  wire [DATA_W-1:0]   a,
    input  wire [DATA_W-1:0]   b,
    input  wire [DATA_W-1:0]   c,
    output wire [3*DATA_W-1:0] sorted  // {high, middle, low}
);
    wire [DATA_W-1:0] ab_low  = (a < b) ? a : b;
    wire [DATA_W-1:0] ab_high = (a < b) ? b : a;
    wire [DATA_W-1:0] low     = (ab_low < c) ? ab_low : c;
    wire [DATA_W-1:0] rest    = (ab_low < c) ? c : ab_low;  // the larger of ab_low and c
    wire [DATA_W-1:0] middle  = (rest < ab_high) ? rest : ab_high;
    wire [DATA_W-1:0] high    = (rest < ab_high) ? ab_high : rest;

    assign sorted = {high, middle, low};
endmodule

`default_nettype wire
