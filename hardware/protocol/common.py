"""Values shared by the packet codecs."""

from __future__ import annotations

from dataclasses import dataclass

from hardware.errors import CorruptPacket

BROADCAST_ID = 0xFE

# Instruction codes common to Dynamixel Protocol 2.0 and Feetech STS/SCS.
PING = 0x01
READ = 0x02
WRITE = 0x03
REG_WRITE = 0x04
ACTION = 0x05
FACTORY_RESET = 0x06
REBOOT = 0x08
SYNC_READ = 0x82
SYNC_WRITE = 0x83
STATUS = 0x55  # Dynamixel 2.0 only: the instruction byte of a status packet


@dataclass(frozen=True)
class Packet:
    """One decoded packet.

    Instruction packets have `error` None; status packets carry the error/status byte.
    For Dynamixel status packets `instruction` is 0x55; for Feetech it is None (the byte
    in that position is the status byte).
    """

    servo_id: int
    instruction: int | None
    params: bytes
    error: int | None = None

    @property
    def is_status(self) -> bool:
        return self.error is not None


class FrameStream:
    """Incremental frame extractor shared by both wire protocols: feed bytes, get whole packets.

    A protocol supplies its `header`, how many bytes it needs to read the length field
    (`prefix_len`), the frame length from that prefix (`_frame_length`, None when the length is
    impossible) and the frame parser (`_parse`). Corrupt frames are skipped and counted in
    `corrupt`; the stream resynchronises on the next header.

    `max_frame` (bytes, optional): a reader that knows how long the frames it waits for can be
    treats a declared length above it as impossible, so a false header in line noise cannot
    hold the stream back waiting for hundreds of bytes that will never come.
    """

    header: bytes = b""
    prefix_len: int = 0

    def __init__(self, max_frame: int | None = None) -> None:
        self._buf = bytearray()
        self.corrupt = 0
        self.max_frame = max_frame

    @property
    def buffered(self) -> int:
        """Bytes held back: an incomplete frame (or header) waiting for the rest."""
        return len(self._buf)

    def _frame_length(self, buf: bytearray) -> int | None:
        raise NotImplementedError

    def _parse(self, frame: bytes) -> Packet:
        raise NotImplementedError

    def _resync(self, buf: bytearray) -> bool:
        """Drop bytes that look like a header but are not one; True if something was dropped."""
        return False

    def feed(self, data: bytes) -> list[Packet]:
        buf = self._buf
        buf.extend(data)
        out: list[Packet] = []
        while True:
            idx = buf.find(self.header)
            if idx < 0:
                del buf[: max(0, len(buf) - (len(self.header) - 1))]  # keep a partial header
                return out
            if idx:
                del buf[:idx]
            if len(buf) < self.prefix_len:
                return out
            if self._resync(buf):
                continue
            total = self._frame_length(buf)
            if total is not None and self.max_frame is not None and total > self.max_frame:
                total = None
            if total is None:
                self.corrupt += 1
                del buf[:1]
                continue
            if len(buf) < total:
                return out
            frame = bytes(buf[:total])
            try:
                out.append(self._parse(frame))
            except CorruptPacket:
                self.corrupt += 1
                del buf[:1]
                continue
            del buf[:total]
