// mx_fn_median5: the running median of the last five samples (the current one and the four
// before), the samples two's-complement signed DATA_W-bit integers; one output per input.
//
// The patrol's line filter in hardware: a single outlier among five readings never reaches the
// output. The history holds the four previous accepted inputs; `clear` (the wrapper's commit)
// and reset zero it, so the first four outputs after either see zeros in place of samples.
// The median is picked by rank, not sorted: sample k's rank counts the samples below it (ties
// broken by position), and the one of rank 2 is the median. Ten signed comparisons, no swaps.
`default_nettype none

module mx_fn_median5 #(
    parameter DATA_W = 32  // payload bits per beat (a signed sample)
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
    reg [DATA_W-1:0] x1_reg;
    reg [DATA_W-1:0] x2_reg;
    reg [DATA_W-1:0] x3_reg;
    reg [DATA_W-1:0] x4_reg;

    wire [5*DATA_W-1:0] window = {x4_reg, x3_reg, x2_reg, x1_reg, in_data};

    // below[k*5 + j]: sample j comes before sample k in the order (smaller, or equal and older
    // in the window's index order), so each sample has a distinct rank 0..4.
    wire [24:0] below;
    reg  [DATA_W-1:0] median;

    genvar k, j;
    generate
        for (k = 0; k < 5; k = k + 1) begin : g_rank
            for (j = 0; j < 5; j = j + 1) begin : g_versus
                if (j == k) begin : g_self
                    assign below[k*5 + j] = 1'b0;
                end else begin : g_other
                    wire signed [DATA_W-1:0] mine = window[k*DATA_W +: DATA_W];
                    wire signed [DATA_W-1:0] other = window[j*DATA_W +: DATA_W];
                    // Equal samples: the one earlier in the window comes first.
                    assign below[k*5 + j] = (j < k) ? (other <= mine) : (other < mine);
                end
            end
        end
    endgenerate

    // The sample with exactly two others before it.
    integer s;
    always @* begin
        median = {DATA_W{1'b0}};
        for (s = 0; s < 5; s = s + 1) begin
            if ({2'b00, below[s*5]} + {2'b00, below[s*5+1]} + {2'b00, below[s*5+2]}
                + {2'b00, below[s*5+3]} + {2'b00, below[s*5+4]} == 3'd2) begin
                median = window[s*DATA_W +: DATA_W];
            end
        end
    end

    always @(posedge clk) begin
        if (rst || clear) begin
            x1_reg <= {DATA_W{1'b0}};
            x2_reg <= {DATA_W{1'b0}};
            x3_reg <= {DATA_W{1'b0}};
            x4_reg <= {DATA_W{1'b0}};
        end else if (in_valid && in_ready) begin
            x1_reg <= in_data;
            x2_reg <= x1_reg;
            x3_reg <= x2_reg;
            x4_reg <= x3_reg;
        end
    end

    mx_pipe #(.DATA_W(DATA_W)) pipe (
        .clk(clk), .rst(rst), .clear(clear),
        .in_valid(in_valid), .in_ready(in_ready), .in_data(median), .in_last(in_last),
        .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data), .out_last(out_last),
        .empty(empty)
    );
endmodule

`default_nettype wire
