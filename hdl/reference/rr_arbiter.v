// rr_arbiter: round-robin arbiter for the shared-bus reference design.
//
// Grants the first requester at or after the pointer; the pointer moves past the granted
// requester when the grant is used (advance), so every requester is served in turn.
`default_nettype none

module rr_arbiter #(
    parameter M = 8  // requesters
) (
    input  wire                 clk,
    input  wire                 rst,
    input  wire [M-1:0]         request,
    input  wire                 advance,    // the granted transfer happened this cycle
    output reg                  granted,    // some requester is granted
    output reg  [$clog2(M)-1:0] grant       // which one
);
    localparam IDX_W = $clog2(M);

    reg [IDX_W-1:0] pointer_reg;
    integer step;
    reg [IDX_W:0] candidate;

    always @* begin
        granted = 1'b0;
        grant = {IDX_W{1'b0}};
        for (step = M - 1; step >= 0; step = step - 1) begin
            candidate = {1'b0, pointer_reg} + step[IDX_W:0];
            if (candidate >= M[IDX_W:0]) candidate = candidate - M[IDX_W:0];
            if (request[candidate[IDX_W-1:0]]) begin
                granted = 1'b1;
                grant = candidate[IDX_W-1:0];
            end
        end
    end

    always @(posedge clk) begin
        if (rst) begin
            pointer_reg <= {IDX_W{1'b0}};
        end else if (advance) begin
            pointer_reg <= (grant == M[IDX_W-1:0] - 1'b1) ? {IDX_W{1'b0}} : grant + 1'b1;
        end
    end
endmodule

`default_nettype wire
