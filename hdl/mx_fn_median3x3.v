// mx_fn_median3x3: a streaming 3x3 median over frames of WIDTH-pixel rows, two line buffers.
//
// A frame is the beats up to and including one marked `last`, in raster order; beat i is pixel
// (i / WIDTH, i % WIDTH). Output i is the median of the nine pixels around pixel i, a neighbour
// outside the frame taken from the nearest pixel inside it: its row clamped into the frame's
// rows, then its column clamped into that row's pixels (the last row may be partial). On frames
// of whole rows this is a median filter with replicated edges.
//
// Output i leaves once input i + WIDTH + 1 has arrived (the pixel below and to the right of i,
// in raster order), so the functionality holds WIDTH + 1 beats. After the frame's `last` it
// flushes them by itself, in_ready low, by running WIDTH + 1 virtual steps: pixels past the end
// of the last row repeat the frame's last pixel, the row below repeats the row above; the last
// output carries `last`. Then it takes the next frame.
//
// A step (one pixel, real or virtual, at column j of row r) reads the two line buffers at j
// (rows r-1 and r-2, one RAM word), sorts the column of three, and shifts it into a window of
// three sorted columns; the median of nine is the median of (the largest low, the median middle,
// the smallest high). A step at j >= 1 emits the window centred on column j - 1 of row r - 1;
// a step at j = 0 emits the right edge of row r - 2 (its window with the last column repeated)
// and starts the new row's window with column 0 repeated. Rows above the frame repeat row 0.
//
// `empty` is high when no beat is held that the functionality could emit on its own (its
// output buffer is empty and no flush is running). The beats of a frame whose `last` has not
// arrived wait for more input, which a reconfiguring wrapper withholds; `clear` (the commit of
// a new source) drops them and starts a new frame.
`default_nettype none

module mx_fn_median3x3 #(
    parameter DATA_W = 8,         // payload bits per beat
    parameter [15:0] WIDTH = 160, // pixels a row (P0), 1..MAX_W
    parameter MAX_W = 1024        // the widest row a functionality may be built for
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
    localparam W = (WIDTH == 16'd0) ? 1 : WIDTH;   // elaboration stops on 0 below
    localparam COL_W = (W > 1) ? $clog2(W) : 1;     // bits of a column index
    localparam LEFT_W = $clog2(W + 2);              // bits of the flush's step count, W + 1
    localparam integer LAST = W - 1;
    localparam integer STEPS = W + 1;
    localparam [COL_W-1:0] LAST_COL = LAST[COL_W-1:0];
    localparam [LEFT_W-1:0] FLUSH_STEPS = STEPS[LEFT_W-1:0];

    // The two line buffers, one word a column: {row r-2, row r-1} at the next step's column.
    reg [2*DATA_W-1:0] lines [0:W-1];

    reg [COL_W-1:0]  col_reg;     // column of the next step
    reg              row1_reg;    // the next step's row is at least 1
    reg              row2_reg;    // ... at least 2
    reg              flush_reg;   // running the virtual steps after `last`
    reg              below_reg;   // the flush reached the row below the frame's last row
    reg [LEFT_W-1:0] left_reg;    // virtual steps still to run
    reg [DATA_W-1:0] final_reg;   // the frame's last pixel
    // The window: two sorted columns {high, middle, low}; the step's own column is the third.
    reg [3*DATA_W-1:0] older_reg;
    reg [3*DATA_W-1:0] newer_reg;

    wire pipe_ready;
    wire step = flush_reg ? pipe_ready : (in_valid && pipe_ready);
    wire wrap = (col_reg == LAST_COL);

    wire [2*DATA_W-1:0] word = lines[col_reg];
    wire [DATA_W-1:0] above = word[DATA_W-1:0];         // row r-1
    wire [DATA_W-1:0] two_above = word[2*DATA_W-1:DATA_W]; // row r-2
    wire [DATA_W-1:0] pixel = !flush_reg ? in_data : (below_reg ? above : final_reg);
    wire [DATA_W-1:0] top = (row1_reg && !row2_reg) ? above : two_above;  // row -1 is row 0

    wire [3*DATA_W-1:0] column;
    mx_sort3 #(.DATA_W(DATA_W)) sort_column (.a(top), .b(above), .c(pixel), .sorted(column));

    // At column 0 the window's right edge repeats its last column; elsewhere the new column
    // comes in.
    wire [3*DATA_W-1:0] third = (col_reg == {COL_W{1'b0}}) ? newer_reg : column;
    wire [DATA_W-1:0] median;
    mx_median9 #(.DATA_W(DATA_W)) pick (
        .left(older_reg), .centre(newer_reg), .right(third), .median(median)
    );

    wire emits = (col_reg == {COL_W{1'b0}}) ? row2_reg : row1_reg;
    wire finishes = flush_reg && (left_reg == {{(LEFT_W-1){1'b0}}, 1'b1});

    assign in_ready = pipe_ready && !flush_reg;

    always @(posedge clk) begin
        if (step) begin
            lines[col_reg] <= {above, pixel};
        end
    end

    always @(posedge clk) begin
        if (step) begin
            older_reg <= (col_reg == {COL_W{1'b0}}) ? column : newer_reg;
            newer_reg <= column;
        end
    end

    always @(posedge clk) begin
        if (rst || clear) begin
            col_reg <= {COL_W{1'b0}};
            row1_reg <= 1'b0;
            row2_reg <= 1'b0;
            flush_reg <= 1'b0;
            below_reg <= 1'b0;
            left_reg <= FLUSH_STEPS;
        end else if (step) begin
            if (finishes) begin  // the frame's last output: the next step starts a new frame
                col_reg <= {COL_W{1'b0}};
                row1_reg <= 1'b0;
                row2_reg <= 1'b0;
                flush_reg <= 1'b0;
                below_reg <= 1'b0;
                left_reg <= FLUSH_STEPS;
            end else begin
                col_reg <= wrap ? {COL_W{1'b0}} : col_reg + {{(COL_W-1){1'b0}}, 1'b1};
                if (wrap) begin
                    row1_reg <= 1'b1;
                    row2_reg <= row1_reg;
                end
                if (flush_reg) begin
                    left_reg <= left_reg - {{(LEFT_W-1){1'b0}}, 1'b1};
                    below_reg <= below_reg || wrap;
                end else if (in_last) begin
                    flush_reg <= 1'b1;
                    below_reg <= wrap;
                    final_reg <= in_data;
                end
            end
        end
    end

    wire pipe_empty;
    mx_pipe #(.DATA_W(DATA_W)) pipe (
        .clk(clk), .rst(rst), .clear(clear),
        .in_valid(step && emits), .in_ready(pipe_ready), .in_data(median), .in_last(finishes),
        .out_valid(out_valid), .out_ready(out_ready), .out_data(out_data), .out_last(out_last),
        .empty(pipe_empty)
    );
    assign empty = pipe_empty && !flush_reg;

    // Elaboration-time check: a row the parameters cannot hold names a module that does not
    // exist, which stops every tool with its name in the message.
    generate
        if (WIDTH == 16'd0 || WIDTH > MAX_W) begin : g_check_width
            mx_error_median3x3_width_not_1_to_max_w bad ();
        end
    endgenerate
endmodule

`default_nettype wire
