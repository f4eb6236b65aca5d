// mx_fn_stretch: the Dehazer's contrast stretch on 8-bit levels, frame by frame.
//
// A frame is the beats up to and including one marked `last`. Every beat leaves at once,
// mapped through a 256-entry table (`last` passed through); meanwhile its level is counted in a
// histogram. After the frame's `last` the functionality stalls its input (in_ready low) for
// STALL = 520 cycles and builds the table the NEXT frame is mapped through:
//   scan   256 cycles  every bin_count in turn, summing the counts, and clearing it: low and high are
//                      the levels of rank n * CLIP / 1000 and n - 1 - that among the frame's n
//                      beats (the clip's percentiles; the rank is kept per beat, with no divider)
//   divide   8 cycles  255 / (high - low), quotient and remainder, one bit a cycle
//   fill   256 cycles  level x maps to 0 up to low, 255 from high on, and in between to
//                      ((x - low) * 255 + spread / 2) / spread, the quotient and remainder
//                      advanced from x - 1 by the division's (no divider per level); every
//                      level to itself when high - low < MIN_SPREAD (or below 0: low above
//                      high, which a CLIP of 500 gives on a frame of an even n)
// exactly visual_servoing/dehaze.py's stretch_table with MIN_SPREAD as a parameter. After reset
// or `clear` it spends 256 cycles (in_ready low) clearing the histogram and setting the table to
// the identity, so frames before its first complete one pass unchanged. A frame's first
// 2^COUNT_W - 1 beats are counted; the beats beyond are mapped but not counted.
`default_nettype none

module mx_fn_stretch #(
    parameter DATA_W = 8,              // payload bits per beat: 8 (elaboration stops otherwise)
    parameter [15:0] CLIP = 10,        // P0: permille clipped at each end, 0..500
    parameter [15:0] MIN_SPREAD = 16,  // P1: the smallest high - low stretched, 0..255
    parameter COUNT_W = 24             // bits of a histogram bin_count
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
    localparam [2:0] S_CLEAR = 3'd0, S_RUN = 3'd1, S_SCAN = 3'd2, S_DIVIDE = 3'd3, S_FILL = 3'd4;
    localparam [COUNT_W-1:0] ONE = {{(COUNT_W-1){1'b0}}, 1'b1};
    localparam [COUNT_W-1:0] FULL = {COUNT_W{1'b1}};
    localparam [10:0] PERMILLE = 11'd1000;

    reg [COUNT_W-1:0] histogram [0:255];  // the frame's histogram
    reg [7:0]         stretch_map [0:255];  // the table: level in, level out

    reg [2:0]         state_reg;
    reg [7:0]         addr_reg;       // the bin_count or level a walk is at; the division's step
    reg [COUNT_W-1:0] count_reg;      // beats counted in this frame, n
    reg [COUNT_W-1:0] rank_reg;       // n * CLIP / 1000, rounded down
    reg [9:0]         permille_reg;   // n * CLIP mod 1000
    reg [COUNT_W-1:0] seen_reg;       // beats in the histogram scanned so far
    reg [7:0]         low_reg;
    reg [7:0]         high_reg;
    reg               low_found_reg;
    reg               high_found_reg;
    reg [7:0]         quotient_reg;   // 255 / spread once divided
    reg [7:0]         remainder_reg;  // the division's partial remainder, then 255 % spread
    reg [7:0]         fill_q_reg;     // ((x - low) * 255 + spread / 2) / spread at the last x
    reg [7:0]         fill_r_reg;     // ... and its remainder

    wire [7:0] level;
    wire       pipe_ready;
    wire       running = (state_reg == S_RUN);
    wire       take = running && in_valid && pipe_ready;
    wire       counting = (count_reg != FULL);
    wire       walked = (addr_reg == 8'd255);

    assign in_ready = running && pipe_ready;

    // The histogram: a read-modify-write per counted beat; the scan and the clearing pass zero
    // each bin_count they pass.
    wire [7:0]         bin_addr = running ? level : addr_reg;
    wire [COUNT_W-1:0] bin_count = histogram[bin_addr];

    always @(posedge clk) begin
        if (state_reg == S_CLEAR || state_reg == S_SCAN) begin
            histogram[addr_reg] <= {COUNT_W{1'b0}};
        end else if (take && counting) begin
            histogram[level] <= bin_count + ONE;
        end
    end

    // The rank of the low percentile, n * CLIP / 1000, kept as each beat is counted.
    wire [10:0] permille_next = {1'b0, permille_reg} + CLIP[10:0];
    wire        rank_up = (permille_next >= PERMILLE);
    wire [COUNT_W-1:0] high_rank = count_reg - rank_reg - ONE;
    wire [COUNT_W-1:0] seen_next = seen_reg + bin_count;

    // The division 255 / spread, restoring, one quotient bit a cycle (255 is all ones).
    wire [7:0] spread = high_reg - low_reg;
    wire [8:0] brought = {remainder_reg, 1'b1};
    wire       fits = (brought >= {1'b0, spread});
    wire [7:0] brought_less = brought[7:0] - spread;  // below spread when it fits: 8 bits

    // The fill: from x - 1 to x the numerator grows by 255 = quotient * spread + remainder.
    wire [8:0] fill_r_sum = {1'b0, fill_r_reg} + {1'b0, remainder_reg};
    wire       carry = (fill_r_sum >= {1'b0, spread});
    wire [7:0] fill_r_less = fill_r_sum[7:0] - spread;  // below spread on a carry: 8 bits
    wire [7:0] fill_q_next = fill_q_reg + quotient_reg + {7'd0, carry};
    wire [7:0] fill_r_next = carry ? fill_r_less : fill_r_sum[7:0];
    // With CLIP = 500 and an even n the low percentile's rank (n / 2) passes the high one's
    // (n / 2 - 1): low may lie above high, a negative spread, which is below any MIN_SPREAD
    // (the 8-bit difference would wrap to a large one).
    wire       crossed = (high_reg < low_reg);
    wire       identity;  // the spread is too small to stretch
    generate
        if (MIN_SPREAD == 16'd0) begin : g_always_stretch
            assign identity = crossed;  // every other spread is at least 0
        end else begin : g_compare_spread
            assign identity = crossed || ({8'd0, spread} < MIN_SPREAD);
        end
    endgenerate
    wire       at_or_below_low = (addr_reg <= low_reg);
    wire [7:0] fill_value = identity ? addr_reg
                          : at_or_below_low ? 8'd0
                          : (addr_reg >= high_reg) ? 8'd255
                          : fill_q_next;

    always @(posedge clk) begin
        if (state_reg == S_CLEAR) begin
            stretch_map[addr_reg] <= addr_reg;
        end else if (state_reg == S_FILL) begin
            stretch_map[addr_reg] <= fill_value;
        end
    end

    always @(posedge clk) begin
        if (rst || clear) begin
            state_reg <= S_CLEAR;
            addr_reg <= 8'd0;
            count_reg <= {COUNT_W{1'b0}};
            rank_reg <= {COUNT_W{1'b0}};
            permille_reg <= 10'd0;
        end else begin
            case (state_reg)
                S_CLEAR: begin
                    addr_reg <= addr_reg + 8'd1;
                    if (walked) state_reg <= S_RUN;
                end
                S_RUN: begin
                    if (take && counting) begin
                        count_reg <= count_reg + ONE;
                        permille_reg <= rank_up ? permille_next[9:0] - PERMILLE[9:0]
                                                : permille_next[9:0];
                        if (rank_up) rank_reg <= rank_reg + ONE;
                    end
                    if (take && in_last) begin
                        state_reg <= S_SCAN;
                        addr_reg <= 8'd0;
                        seen_reg <= {COUNT_W{1'b0}};
                        low_found_reg <= 1'b0;
                        high_found_reg <= 1'b0;
                    end
                end
                S_SCAN: begin
                    seen_reg <= seen_next;
                    if (!low_found_reg && seen_next > rank_reg) begin
                        low_reg <= addr_reg;
                        low_found_reg <= 1'b1;
                    end
                    if (!high_found_reg && seen_next > high_rank) begin
                        high_reg <= addr_reg;
                        high_found_reg <= 1'b1;
                    end
                    addr_reg <= addr_reg + 8'd1;
                    if (walked) begin  // the next frame counts afresh
                        state_reg <= S_DIVIDE;
                        addr_reg <= 8'd0;
                        remainder_reg <= 8'd0;
                        count_reg <= {COUNT_W{1'b0}};
                        rank_reg <= {COUNT_W{1'b0}};
                        permille_reg <= 10'd0;
                    end
                end
                S_DIVIDE: begin
                    remainder_reg <= fits ? brought_less : brought[7:0];
                    quotient_reg <= {quotient_reg[6:0], fits};
                    addr_reg <= addr_reg + 8'd1;
                    if (addr_reg == 8'd7) begin
                        state_reg <= S_FILL;
                        addr_reg <= 8'd0;
                    end
                end
                default: begin  // S_FILL
                    fill_q_reg <= at_or_below_low ? 8'd0 : fill_q_next;
                    fill_r_reg <= at_or_below_low ? {1'b0, spread[7:1]} : fill_r_next;
                    addr_reg <= addr_reg + 8'd1;
                    if (walked) state_reg <= S_RUN;
                end
            endcase
        end
    end

    wire [DATA_W-1:0] mapped;
    mx_pipe #(.DATA_W(DATA_W)) pipe (
        .clk(clk), .rst(rst), .clear(clear),
        .in_valid(take), .in_ready(pipe_ready), .in_data(mapped), .in_last(in_last),
        .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data), .out_last(out_last),
        .empty(empty)
    );

    // Elaboration-time checks: parameters the stretch cannot take name a module that does not
    // exist, which stops every tool with its name in the message.
    generate
        if (DATA_W == 8) begin : g_levels
            assign level = in_data;
            assign mapped = stretch_map[level];
        end else begin : g_bad_width
            mx_error_stretch_needs_data_w_8 bad ();
        end
        if (CLIP > 16'd500) begin : g_check_clip
            mx_error_stretch_clip_above_500 bad ();
        end
        if (MIN_SPREAD > 16'd255) begin : g_check_spread
            mx_error_stretch_min_spread_above_255 bad ();
        end
    endgenerate
endmodule

`default_nettype wire
