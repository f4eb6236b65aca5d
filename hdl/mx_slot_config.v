// mx_slot_config: the reconfiguration control of one wrapper.
//
// Receives a partial bitstream on the configuration shift-in port, CFG_W bits a beat, most
// significant bit first. The frame (morphing_crossbar/bitstream.py packs it) is
//     {MAGIC 4'hA, SLOT 4 bits, FSEL SEL_W bits, OSEL SEL_W bits, CRC-8 of the rest}
// From the first beat until the frame is settled the slot is isolated: its functionality takes no
// new beat, and the beats it already holds drain to the old destination. Then the frame is
// checked; a good one is committed atomically (one clock edge switches both selectors and, when
// the functionality's source changes, clears its history), a bad one is refused with the old
// routing untouched. A frame that keeps FSEL (only the output port moves, as when the Morphing
// Bus re-plugs a board onto this slot's port) leaves the history alone: the stream through the
// functionality is the same one, and clearing it would corrupt another board's filter.
// Latency from the first beat to the new routing: BITS / CFG_W + 1 cycles once the
// functionality is empty.
//
// Error codes (cfg_error_code, valid with the cfg_error pulse):
//   1 CRC mismatch, 2 wrong length, 3 bad magic, 4 frame for another slot,
//   5 selector out of range, 6 refused route (one source twice, or the slot feeding itself).
`default_nettype none

module mx_slot_config #(
    parameter SLOT_ID = 0,          // this slot's index, checked against the frame
    parameter NSRC = 4,             // sources each selector can choose (index 0 = none)
    parameter SEL_W = 4,            // selector field width in the frame
    parameter CFG_W = 1,            // configuration port width (bits a beat)
    parameter SELF_SRC = 0,         // source index of this slot's own functionality output
    parameter RESET_FSEL = 1,       // functionality input after reset
    parameter RESET_OSEL = 0        // output port source after reset
) (
    input  wire             clk,
    input  wire             rst,
    input  wire             cfg_valid,
    input  wire [CFG_W-1:0] cfg_data,
    input  wire             cfg_last,
    input  wire             drained,        // the functionality holds no beat
    output reg  [SEL_W-1:0] fsel,           // active source of the functionality input
    output reg  [SEL_W-1:0] osel,           // active source of the output port
    output wire             isolate,        // decouple the functionality input
    output wire             clear,          // the commit edge of a new FSEL: clear the history
    output reg              commit,         // one-cycle pulse: the new routing is in force
    output reg              error,          // one-cycle pulse: frame refused
    output reg  [2:0]       error_code
);
    localparam BITS = 16 + 2 * SEL_W;
    localparam BEATS = BITS / CFG_W;
    localparam MSG_W = BITS - 8;
    localparam [1:0] S_IDLE = 2'd0, S_SHIFT = 2'd1, S_CHECK = 2'd2;

    reg [BITS-1:0] frame_reg;
    reg [7:0]      beats_reg;   // beats received, saturating
    reg [1:0]      state_reg;

    wire [7:0]       crc;
    wire [3:0]       magic   = frame_reg[BITS-1 -: 4];
    wire [3:0]       slot    = frame_reg[BITS-5 -: 4];
    wire [SEL_W-1:0] new_fsel = frame_reg[8 + SEL_W +: SEL_W];
    wire [SEL_W-1:0] new_osel = frame_reg[8 +: SEL_W];

    mx_crc8 #(.MSG_W(MSG_W)) crc8 (.msg(frame_reg[BITS-1:8]), .crc(crc));

    // The first reason a settled frame is refused, or 0 when it is good.
    reg [2:0] verdict;
    always @* begin
        if (beats_reg != BEATS[7:0])                                      verdict = 3'd2;
        else if (crc != frame_reg[7:0])                                   verdict = 3'd1;
        else if (magic != 4'hA)                                           verdict = 3'd3;
        else if (slot != SLOT_ID[3:0])                                    verdict = 3'd4;
        else if ({1'b0, new_fsel} >= NSRC[SEL_W:0]
                 || {1'b0, new_osel} >= NSRC[SEL_W:0])                 verdict = 3'd5;
        else if ((new_fsel != 0 && new_fsel == new_osel)
                 || new_fsel == SELF_SRC[SEL_W-1:0])                      verdict = 3'd6;
        else                                                              verdict = 3'd0;
    end

    // A settled, good frame and an empty functionality: switch at this clock edge.
    wire accept = (state_reg == S_CHECK) && (verdict == 3'd0) && drained;

    assign isolate = (state_reg != S_IDLE);
    assign clear = accept && (new_fsel != fsel);

    always @(posedge clk) begin
        commit <= 1'b0;
        error <= 1'b0;
        if (rst) begin
            state_reg <= S_IDLE;
            beats_reg <= 8'd0;
            fsel <= RESET_FSEL[SEL_W-1:0];
            osel <= RESET_OSEL[SEL_W-1:0];
            error_code <= 3'd0;
        end else begin
            case (state_reg)
                S_IDLE, S_SHIFT: begin
                    if (cfg_valid) begin
                        frame_reg <= {frame_reg[BITS-CFG_W-1:0], cfg_data};
                        beats_reg <= (state_reg == S_IDLE) ? 8'd1
                                   : (beats_reg == 8'hFF) ? beats_reg : beats_reg + 8'd1;
                        state_reg <= cfg_last ? S_CHECK : S_SHIFT;
                    end
                end
                default: begin  // S_CHECK
                    if (verdict != 3'd0) begin
                        error <= 1'b1;
                        error_code <= verdict;
                        state_reg <= S_IDLE;
                    end else if (accept) begin
                        fsel <= new_fsel;
                        osel <= new_osel;
                        commit <= 1'b1;
                        state_reg <= S_IDLE;
                    end
                end
            endcase
        end
    end

    // Elaboration-time checks: a bad configuration instantiates a module that does not exist,
    // which stops every tool (simulators, Verilator, yosys) with its name in the message.
    generate
        if (BITS % CFG_W != 0) begin : g_check_cfg_w
            mx_error_cfg_w_must_divide_frame_bits bad ();
        end
        if (NSRC > (1 << SEL_W) || NSRC < 2) begin : g_check_nsrc
            mx_error_sources_do_not_fit_selector bad ();
        end
        if (SLOT_ID > 15) begin : g_check_slot
            mx_error_slot_id_above_15 bad ();
        end
    endgenerate
endmodule

`default_nettype wire
