# Bump every frame vector in core/tests/wire_vectors.rs from protocol version OLD to NEW
# (`python3 tools/wire_vectors/bump_version.py OLD NEW`):
# COBS-decode each line literal (independent reference, tools/wire_vectors/wire_ref.py), check it
# against its CRC literal, set the version byte (and Hello's body, which is the version; the
# Capabilities vector's version field is a value of its own and stays), recompute CRC-32C and
# COBS, and rewrite the literals.
import os, re, sys, struct
HERE = os.path.dirname(os.path.abspath(__file__))
exec(open(os.path.join(HERE, 'wire_ref.py')).read())
OLD, NEW = int(sys.argv[1]), int(sys.argv[2])
VECTORS = os.path.join(HERE, '..', '..', 'core', 'tests', 'wire_vectors.rs')
def cobs_decode(b):
    out = bytearray(); i = 0
    while i < len(b):
        code = b[i]; i += 1
        out += b[i:i+code-1]; i += code-1
        if code < 255 and i < len(b): out.append(0)
    return bytes(out)
src = open(VECTORS).read()
pos = 0; out = []; n = 0
pat = re.compile(r'check_vector\(')
for m in pat.finditer(src):
    if src[m.start()-3:m.start()] == 'fn ': continue
    # find the crc literal and the line literal after this call
    seg_start = m.end()
    depth = 1; i = seg_start
    while depth:
        c = src[i]
        if c == '(': depth += 1
        elif c == ')': depth -= 1
        i += 1
    call = src[seg_start:i-1]
    crcm = list(re.finditer(r'0x[0-9A-F]{4}_[0-9A-F]{4}', call))
    assert crcm, call[:200]
    crc_lit = crcm[-1]
    after = call[crc_lit.end():]
    lm = re.search(r'&\[([^\]]*)\]', after)
    if lm is None:
        print('no line literal in call at', m.start(), file=sys.stderr); sys.exit(1)
    line = bytes(int(x, 16) for x in re.findall(r'0x[0-9A-Fa-f]{2}', lm.group(1)))
    assert line[-1] == 0
    fr = cobs_decode(line[:-1])
    body, crc = fr[:-4], struct.unpack("<I", fr[-4:])[0]
    assert crc == int(crc_lit.group(0).replace('_',''), 16), 'crc literal'
    assert crc32c(body) == crc, 'crc'
    assert body[0] == OLD, body[0]
    body = bytearray(body); body[0] = NEW
    cmd = body[3]
    if cmd == 0x01:  # Hello: its body is the version
        assert body[6] == OLD; body[6] = NEW
    c2, line2 = frame(NEW, body[1], body[2], body[3], bytes(body[6:]))
    assert struct.unpack('<H', bytes(body[4:6]))[0] == len(body) - 6
    new_crc = '0x%04X_%04X' % (c2 >> 16, c2 & 0xFFFF)
    new_line = ', '.join('0x%02X' % b for b in line2)
    # rebuild call text
    a0 = seg_start + crc_lit.start(); a1 = seg_start + crc_lit.end()
    l0 = seg_start + crc_lit.end() + lm.start(1); l1 = seg_start + crc_lit.end() + lm.end(1)
    out.append((a0, a1, new_crc)); out.append((l0, l1, new_line))
    n += 1
for a, b, s in sorted(out, reverse=True):
    src = src[:a] + s + src[b:]
open(VECTORS, 'w').write(src)
print(n, 'vectors bumped')
