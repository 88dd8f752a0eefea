# Independent implementation (from the spec in core/src/wire/mod.rs) of CRC-32C and COBS, used to
# produce the expected line bytes of the hand-written vectors in core/tests/wire_vectors.rs.
import struct, sys
def crc32c(data):
    c = 0xFFFFFFFF
    for b in data:
        c ^= b
        for _ in range(8):
            c = (c >> 1) ^ 0x82F63B78 if c & 1 else c >> 1
    return c ^ 0xFFFFFFFF
def cobs(data):
    out = bytearray(); block = bytearray()
    for b in data:
        if b == 0:
            out.append(len(block)+1); out += block; block = bytearray()
        else:
            block.append(b)
            if len(block) == 254:
                out.append(255); out += block; block = bytearray()
    out.append(len(block)+1); out += block
    return bytes(out)
def frame(ver, flags, seq, cmd, payload):
    f = bytes([ver, flags, seq, cmd]) + struct.pack('<H', len(payload)) + bytes(payload)
    c = crc32c(f)
    return c, cobs(f + struct.pack('<I', c)) + b'\0'
def f64(x): return list(struct.pack('<d', x))
assert crc32c(b'123456789') == 0xE3069283
# v1 cross-checks against the vectors as they were
assert frame(1,2,7,0x32,[]) == (0x0FB1A492, bytes([0x05,0x01,0x02,0x07,0x32,0x01,0x05,0x92,0xA4,0xB1,0x0F,0x00]))
assert frame(1,2,1,0x01,[1])[0] == 0xBACF320F
assert frame(1,0,9,0x81,[0x12])[0] == 0xF58A64F9
def rust(c, line):
    s = "        0x%04X_%04X,\n        &[\n" % (c >> 16, c & 0xFFFF)
    for i in range(0, len(line), 14):
        s += "            " + ", ".join("0x%02X" % b for b in line[i:i+14]) + ",\n"
    return s + "        ],"
