// mx_median9: the median of nine values given as three sorted columns ({high, middle, low}
// each, from mx_sort3): the median of the largest low, the median middle and the smallest high.
//
// That identity (the last stages of the classic median-of-nine network) lets mx_fn_median3x3
// sort each column once, when it comes in, and share it between the three windows it belongs
// to: 9 comparisons a pixel here and 3 in the sort, against 19 for a network on nine values.
`default_nettype none

module mx_median9 #(
    parameter DATA_W = 8  // bits of a value
) (
    input  wire [3*DATA_W-1:0] left,
    input  wire [3*DATA_W-1:0] centre,
    input  wire [3*DATA_W-1:0] right,
    output wire [DATA_W-1:0]   median
);
    function [DATA_W-1:0] larger(input [DATA_W-1:0] a, input [DATA_W-1:0] b);
        larger = (a < b) ? b : a;
    endfunction

    function [DATA_W-1:0] smaller(input [DATA_W-1:0] a, input [DATA_W-1:0] b);
        smaller = (a < b) ? a : b;
    endfunction

    function [DATA_W-1:0] middle(input [DATA_W-1:0] a, input [DATA_W-1:0] b,
                                 input [DATA_W-1:0] c);
        middle = larger(smaller(a, b), smaller(larger(a, b), c));
    endfunction

    localparam LOW = 0, MID = DATA_W, HIGH = 2 * DATA_W;

    wire [DATA_W-1:0] lows_max = larger(larger(left[LOW +: DATA_W], centre[LOW +: DATA_W]),
                                        right[LOW +: DATA_W]);
    wire [DATA_W-1:0] middles_median = middle(left[MID +: DATA_W], centre[MID +: DATA_W],
                                              right[MID +: DATA_W]);
    wire [DATA_W-1:0] highs_min = smaller(smaller(left[HIGH +: DATA_W], centre[HIGH +: DATA_W]),
                                          right[HIGH +: DATA_W]);

    assign median = middle(lows_max, middles_median, highs_min);
endmodule

`default_nettype wire
