// mx_wrapper: the wrapper half of a slot, the only part partial reconfiguration changes.
//
// It owns the slot's routing state (two selectors) and the reconfiguration control
// (mx_slot_config). FSEL picks the source of the functionality's input, OSEL the source of the
// slot's output port; source 0 is "none". The sources themselves (external inputs, the ring
// neighbour, the local crossbar) are wired by the fabric around it, so the same wrapper serves
// the morphing crossbar and the full-crossbar reference. While a new frame arrives the
// functionality input is isolated (ready and valid held low); the output port keeps its old
// route until the commit edge switches both selectors at once.
`default_nettype none

module mx_wrapper #(
    parameter SLOT_ID = 0,     // this slot's index
    parameter DATA_W = 8,      // payload bits per beat
    parameter NSRC = 4,        // sources each selector can choose (index 0 = none)
    parameter SEL_W = 4,       // selector field width in the frame
    parameter CFG_W = 1,       // configuration port width
    parameter SELF_SRC = 0,    // source index of this slot's own functionality output
    parameter RESET_FSEL = 1,  // functionality input after reset
    parameter RESET_OSEL = 0   // output port source after reset
) (
    input  wire                   clk,
    input  wire                   rst,
    // configuration shift-in port
    input  wire                   cfg_valid,
    input  wire [CFG_W-1:0]       cfg_data,
    input  wire                   cfg_last,
    output wire                   cfg_commit,
    output wire                   cfg_error,
    output wire [2:0]             cfg_error_code,
    output wire                   busy,
    // candidate sources, index 0 unused (none)
    input  wire [NSRC-1:0]        src_valid,
    output wire [NSRC-1:0]        src_ready,
    input  wire [NSRC*DATA_W-1:0] src_data,
    input  wire [NSRC-1:0]        src_last,
    // to and from the functionality
    output wire                   fn_in_valid,
    input  wire                   fn_in_ready,
    output wire [DATA_W-1:0]      fn_in_data,
    output wire                   fn_in_last,
    input  wire                   fn_empty,
    output wire                   fn_clear,
    // the slot's output port
    output wire                   out_valid,
    input  wire                   out_ready,
    output wire [DATA_W-1:0]      out_data,
    output wire                   out_last
);
    wire [SEL_W-1:0] fsel;
    wire [SEL_W-1:0] osel;
    wire             isolate;

    mx_slot_config #(
        .SLOT_ID(SLOT_ID), .NSRC(NSRC), .SEL_W(SEL_W), .CFG_W(CFG_W), .SELF_SRC(SELF_SRC),
        .RESET_FSEL(RESET_FSEL), .RESET_OSEL(RESET_OSEL)
    ) config_unit (
        .clk(clk), .rst(rst),
        .cfg_valid(cfg_valid), .cfg_data(cfg_data), .cfg_last(cfg_last),
        .drained(fn_empty),
        .fsel(fsel), .osel(osel), .isolate(isolate),
        .clear(fn_clear), .commit(cfg_commit), .error(cfg_error), .error_code(cfg_error_code)
    );

    assign busy = isolate;

    // The sources padded to every value a selector can hold (the padding is never selected:
    // mx_slot_config refuses out-of-range selectors).
    localparam SPACE = 1 << SEL_W;
    wire [SPACE-1:0]        any_valid;
    wire [SPACE*DATA_W-1:0] any_data;
    wire [SPACE-1:0]        any_last;

    assign fn_in_valid = any_valid[fsel] && !isolate;
    assign fn_in_data  = any_data[fsel*DATA_W +: DATA_W];
    assign fn_in_last  = any_last[fsel];

    assign out_valid = any_valid[osel];
    assign out_data  = any_data[osel*DATA_W +: DATA_W];
    assign out_last  = any_last[osel];

    genvar s;
    generate
        for (s = 0; s < SPACE; s = s + 1) begin : g_space
            if (s < NSRC) begin : g_source
                assign any_valid[s] = src_valid[s];
                assign any_data[s*DATA_W +: DATA_W] = src_data[s*DATA_W +: DATA_W];
                assign any_last[s] = src_last[s];
            end else begin : g_padding
                assign any_valid[s] = 1'b0;
                assign any_data[s*DATA_W +: DATA_W] = {DATA_W{1'b0}};
                assign any_last[s] = 1'b0;
            end
        end
        for (s = 0; s < NSRC; s = s + 1) begin : g_ready
            assign src_ready[s] = (fsel == s && fn_in_ready && !isolate)
                               || (osel == s && out_ready);
        end
    endgenerate
endmodule

`default_nettype wire
