"""How long bytes and frames take on the node's UART and CAN wires.

A module transfer is limited by its wire long before the flash or the CPU: 115200 baud carries at
most 11,520 payload bytes per second, and a CAN frame needs 111 to 135 bits on the wire for
its 8 data bytes. These functions give the exact time on the wire, so a transfer's measured
throughput can be compared with what the wire allows (for scale: the Optiboot bootloader reaches
3,430 B/s at 115200 baud).

UART 8N1: one start bit, 8 data bits, no parity, one stop bit: 10 bits per byte.

Classic CAN 2.0A (11-bit identifier) and 2.0B (29-bit identifier) data frames, as ISO 11898-1
lays them out (bits in brackets)::

    standard: SOF[1] id[11] RTR[1] IDE[1] r0[1]                           DLC[4] data[8n] CRC[15]
    extended: SOF[1] id[11] SRR[1] IDE[1] id[18] RTR[1] r1[1] r0[1]        DLC[4] data[8n] CRC[15]
    then:     CRC delimiter[1] ACK slot[1] ACK delimiter[1] EOF[7] intermission[3]

From SOF through the CRC sequence the transmitter inserts a complementary stuff bit after every
five equal bits (stuff bits count toward the next run); the fixed-form tail (CRC delimiter 1,
ACK slot 1, ACK delimiter 1, EOF 7, intermission 3 = 13 bits) is never stuffed. So a frame's
length depends on its identifier, data and CRC, which `can_frame_bits` computes exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

WIRES = ("serial", "CAN")
"""The wires this package times: a UART line and a CAN bus."""
UART_BITS_PER_BYTE = 10  # 8N1: start bit, 8 data bits, stop bit

CAN_MAX_DATA = 8
CAN_STANDARD_ID_BITS = 11
CAN_EXTENDED_ID_BITS = 29
CRC15_POLYNOMIAL = 0x4599  # x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1
CRC15_BITS = 15
STUFF_RUN = 5  # after this many equal bits the transmitter inserts a complementary bit
# Bits after the CRC sequence, never stuffed: CRC delimiter, ACK slot, ACK delimiter, EOF (7)
# and the intermission (3) that separates this frame from the next one.
CAN_TAIL_BITS = 1 + 1 + 1 + 7 + 3
# Bits from SOF through the DLC: SOF, id 11, RTR, IDE, r0, DLC 4 (standard); SOF, base id 11,
# SRR, IDE, extended id 18, RTR, r1, r0, DLC 4 (extended).
CAN_HEADER_BITS = {False: 1 + 11 + 3 + 4, True: 1 + 11 + 2 + 18 + 3 + 4}


def uart_seconds(byte_count: int, baudrate: float) -> float:
    """Seconds that `byte_count` bytes take on an 8N1 UART at `baudrate` bits per second."""
    _check_rate(baudrate, "baud rate")
    if byte_count < 0:
        raise ValueError(f"expected a byte count >= 0, got {byte_count}")
    return byte_count * UART_BITS_PER_BYTE / baudrate


def uart_byte_rate(baudrate: float) -> float:
    """The most payload bytes per second an 8N1 UART carries: 11,520 at 115200 baud."""
    _check_rate(baudrate, "baud rate")
    return baudrate / UART_BITS_PER_BYTE


def can_crc15(bits: list[int]) -> int:
    """The CAN CRC-15 of a bit sequence (ISO 11898-1: polynomial 0x4599, initial value 0)."""
    crc = 0
    for bit in bits:
        feedback = bit ^ (crc >> (CRC15_BITS - 1))
        crc = (crc << 1) & ((1 << CRC15_BITS) - 1)
        if feedback:
            crc ^= CRC15_POLYNOMIAL
    return crc


def can_frame_fields(arbitration_id: int, data: bytes, extended: bool = False) -> list[int]:
    """The unstuffed bits of a data frame from SOF through the CRC sequence (0 is dominant)."""
    _check_frame(arbitration_id, len(data), extended)
    if extended:
        base, extension = arbitration_id >> 18, arbitration_id & 0x3FFFF
        # SRR and IDE are recessive in an extended frame; then RTR, r1 and r0 dominant.
        header = [0, *_bits(base, 11), 1, 1, *_bits(extension, 18), 0, 0, 0]
    else:
        header = [0, *_bits(arbitration_id, 11), 0, 0, 0]  # SOF, id, RTR, IDE, r0
    frame = header + _bits(len(data), 4) + [bit for byte in data for bit in _bits(byte, 8)]
    return frame + _bits(can_crc15(frame), CRC15_BITS)


def stuff_bit_count(bits: list[int]) -> int:
    """How many stuff bits a transmitter inserts into `bits`: one after every five equal bits,
    the stuff bit itself starting the next run."""
    inserted = 0
    run_bit, run = -1, 0
    for bit in bits:
        if bit == run_bit:
            run += 1
        else:
            run_bit, run = bit, 1
        if run == STUFF_RUN:
            inserted += 1
            run_bit, run = 1 - bit, 1
    return inserted


def can_frame_bits(arbitration_id: int, data: bytes, extended: bool = False) -> int:
    """The exact number of bits one data frame occupies on the wire, with its stuff bits, the
    fixed-form tail and the 3-bit intermission."""
    fields = can_frame_fields(arbitration_id, data, extended)
    return len(fields) + stuff_bit_count(fields) + CAN_TAIL_BITS


def can_frame_bits_worst(dlc: int, extended: bool = False) -> int:
    """The most bits a data frame of `dlc` bytes can take, whatever its identifier and data.

    With ``g`` = 34 (standard) or 54 (extended) stuffable bits besides the data (SOF through
    DLC, and the CRC), the stuffed region is ``g + 8*dlc`` bits long and holds at most
    ``floor((g + 8*dlc - 1) / 4)`` stuff bits (the first after five equal bits, then one every
    four), so::

        bits = g + 8*dlc + 13 + floor((g + 8*dlc - 1) / 4)

    which is 135 for 8 bytes in a standard frame and 160 in an extended one (Davis et al., 2007,
    with the 3-bit intermission counted as part of the frame).
    """
    _check_frame(0, dlc, extended)
    stuffable = CAN_HEADER_BITS[extended] + CRC15_BITS + 8 * dlc
    return stuffable + CAN_TAIL_BITS + (stuffable - 1) // (STUFF_RUN - 1)


def can_seconds(bits: int, bitrate: float) -> float:
    """Seconds that `bits` take on a CAN bus at `bitrate` bits per second."""
    _check_rate(bitrate, "bit rate")
    if bits < 0:
        raise ValueError(f"expected a bit count >= 0, got {bits}")
    return bits / bitrate


@dataclass
class WireClock:
    """One direction of a wire in virtual time: a frame or byte chunk cannot start before the
    previous one has left, so sends queue behind each other as on a real wire.

    `free_at` is when the wire is next idle; `deliver*` returns when the last bit of what was
    sent at `at` arrives. A transfer's time on the wire is the last arrival minus the first
    send, to set against `uart_byte_rate` or the bit rate.
    """

    bitrate: float
    free_at: float = 0.0

    def __post_init__(self) -> None:
        _check_rate(self.bitrate, "bit rate")

    def deliver(self, bits: int, at: float) -> float:
        """Send `bits` at virtual time `at` (or when the wire frees up); return their arrival."""
        if bits < 0:
            raise ValueError(f"expected a bit count >= 0, got {bits}")
        self.free_at = max(at, self.free_at) + bits / self.bitrate
        return self.free_at

    def deliver_uart(self, byte_count: int, at: float) -> float:
        """Send `byte_count` bytes as 8N1 characters; return when the last stop bit arrives."""
        if byte_count < 0:
            raise ValueError(f"expected a byte count >= 0, got {byte_count}")
        return self.deliver(byte_count * UART_BITS_PER_BYTE, at)

    def deliver_can(
        self, arbitration_id: int, data: bytes, at: float, extended: bool = False
    ) -> float:
        """Send one CAN data frame; return when its intermission ends and the next may start."""
        return self.deliver(can_frame_bits(arbitration_id, data, extended), at)


def _bits(value: int, width: int) -> list[int]:
    """`value` as `width` bits, most significant first (the order CAN transmits)."""
    return [(value >> shift) & 1 for shift in range(width - 1, -1, -1)]


def _check_frame(arbitration_id: int, length: int, extended: bool) -> None:
    width = CAN_EXTENDED_ID_BITS if extended else CAN_STANDARD_ID_BITS
    if not 0 <= arbitration_id < 1 << width:
        kind = "extended" if extended else "standard"
        raise ValueError(
            f"expected a {kind} CAN identifier of {width} bits (0..0x{(1 << width) - 1:X}), "
            f"got 0x{arbitration_id:X}"
        )
    if not 0 <= length <= CAN_MAX_DATA:
        raise ValueError(f"expected 0 to {CAN_MAX_DATA} data bytes in a CAN frame, got {length}")


def _check_rate(rate: float, what: str) -> None:
    if not rate > 0:
        raise ValueError(f"expected a {what} > 0 bits per second, got {rate}")
