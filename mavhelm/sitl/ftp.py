"""MAVLink FTP (FILE_TRANSFER_PROTOCOL) with no file system behind it (libraries/GCS_MAVLink/
GCS_FTP.cpp's reply layout): every file is missing, so a client's MAVFTP parameter download
fails at once and it falls back to PARAM_REQUEST_LIST instead of timing out."""

from __future__ import annotations

# opcodes and NAK error codes
FTP_NONE, FTP_TERMINATE, FTP_RESET, FTP_READ, FTP_WRITE, FTP_BURST_READ = 0, 1, 2, 5, 7, 15
FTP_NAMED = {3, 4, 6, 8, 9, 10, 11, 12, 13, 14}  # list, open, create, remove, mkdir, crc, …
FTP_ACK, FTP_NAK = 128, 129
FTP_ERR_FAIL_ERRNO, FTP_ERR_UNKNOWN_COMMAND, FTP_ERR_FILE_NOT_FOUND = 2, 7, 10
ENOENT = 2
PAYLOAD_SIZE = 251


def ftp_reply(payload: bytes) -> bytes | None:
    """The reply payload to a request payload, or None (too short, or not a request).

    As GCS_FTP: seq + 1, same session, req_opcode = the request's opcode, NAK with the error
    code in data[0] (FailErrno also carries errno in data[1])."""
    if len(payload) < 12:
        return None
    seq = payload[0] | (payload[1] << 8)
    session, opcode = payload[2], payload[3]
    if opcode in (FTP_ACK, FTP_NAK):
        return None  # not a request: ArduPilot eats these
    data = b""
    if opcode in (FTP_NONE, FTP_TERMINATE, FTP_RESET):
        reply = FTP_ACK  # nothing is open, so closing succeeds
    elif opcode in FTP_NAMED:
        reply, data = FTP_NAK, bytes((FTP_ERR_FAIL_ERRNO, ENOENT))  # as for a missing file
    elif opcode in (FTP_READ, FTP_WRITE, FTP_BURST_READ):
        reply, data = FTP_NAK, bytes((FTP_ERR_FILE_NOT_FOUND,))  # no file open
    else:
        reply, data = FTP_NAK, bytes((FTP_ERR_UNKNOWN_COMMAND,))
    out = (bytes(((seq + 1) & 0xFF, ((seq + 1) >> 8) & 0xFF, session, reply, len(data),
                  opcode, 0, 0, 0, 0, 0, 0)) + data)
    return out.ljust(PAYLOAD_SIZE, b"\0")
