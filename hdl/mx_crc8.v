// mx_crc8: CRC-8 (polynomial 0x07, initial value 0, no reflection) of a MSG_W-bit message,
// most significant bit first.
//
// Combinational: the wrapper checks a whole frame at once, after its last beat, so the CRC costs
// no cycles. The Python packer (morphing_crossbar/crc.py) computes the same value.
`default_nettype none

module mx_crc8 #(
    parameter MSG_W = 16  // message bits
) (
    input  wire [MSG_W-1:0] msg,
    output wire [7:0]       crc
);
    function [7:0] crc8;
        input [MSG_W-1:0] bits;
        integer k;
        reg [7:0] acc;
        begin
            acc = 8'h00;
            for (k = MSG_W - 1; k >= 0; k = k - 1) begin
                acc = (acc[7] ^ bits[k]) ? {acc[6:0], 1'b0} ^ 8'h07 : {acc[6:0], 1'b0};
            end
            crc8 = acc;
        end
    endfunction

    assign crc = crc8(msg);
endmodule

`default_nettype wire
