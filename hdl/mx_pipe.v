// mx_pipe: a two-entry stream buffer with a registered ready.
//
// Every functionality ends in one of these. Its input ready depends only on its own occupancy
// register, never on the downstream ready, so the hybrid routing (ring plus local crossbar) has
// no combinational ready path from one slot to another: any routing the wrappers choose is free
// of combinational loops. Two entries keep one beat per cycle under full load.
`default_nettype none

module mx_pipe #(
    parameter DATA_W = 8  // payload bits per beat
) (
    input  wire              clk,
    input  wire              rst,
    input  wire              clear,      // drop both entries (wrapper commit; unused when empty)
    input  wire              in_valid,
    output wire              in_ready,
    input  wire [DATA_W-1:0] in_data,
    input  wire              in_last,
    output wire              out_valid,
    input  wire              out_ready,
    output wire [DATA_W-1:0] out_data,
    output wire              out_last,
    output wire              empty       // no beat held: the wrapper may commit a new route
);
    reg [DATA_W:0] head_reg;   // {last, data} of the oldest beat
    reg [DATA_W:0] tail_reg;   // {last, data} of the second beat
    reg [1:0]      count_reg;  // 0, 1 or 2 beats held

    wire push = in_valid && in_ready;
    wire pop  = out_valid && out_ready;

    assign in_ready  = (count_reg != 2'd2);
    assign out_valid = (count_reg != 2'd0);
    assign out_data  = head_reg[DATA_W-1:0];
    assign out_last  = head_reg[DATA_W];
    assign empty     = (count_reg == 2'd0);

    always @(posedge clk) begin
        if (rst || clear) begin
            count_reg <= 2'd0;
        end else begin
            case ({push, pop})
                2'b10: count_reg <= count_reg + 2'd1;
                2'b01: count_reg <= count_reg - 2'd1;
                default: count_reg <= count_reg;
            endcase
        end
    end

    always @(posedge clk) begin
        if (push && (count_reg == 2'd0 || (count_reg == 2'd1 && pop))) begin
            head_reg <= {in_last, in_data};
        end else if (pop) begin
            head_reg <= tail_reg;
        end
        if (push) begin
            tail_reg <= {in_last, in_data};
        end
    end
endmodule

`default_nettype wire
