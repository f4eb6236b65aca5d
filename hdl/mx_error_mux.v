// mx_error_mux: the error code of the slot that refused a frame (only one slot is addressed at
// a time, so at most one error bit is set).
`default_nettype none

module mx_error_mux #(
    parameter N = 4  // slots
) (
    input  wire [N-1:0]   error,
    input  wire [3*N-1:0] codes,
    output reg  [2:0]     code
);
    integer s;
    always @* begin
        code = 3'd0;
        for (s = 0; s < N; s = s + 1) begin
            code = code | (error[s] ? codes[3*s +: 3] : 3'd0);
        end
    end
endmodule

`default_nettype wire
