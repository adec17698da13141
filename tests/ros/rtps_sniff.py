"""Log the RTPS discovery traffic on the loopback interface (issue 13 diagnostics).

    sudo python tests/ros/rtps_sniff.py OUT.log [--domain D]

Reads every UDP datagram on `lo` through a raw packet socket (Linux, needs root or
CAP_NET_RAW; it only listens, nothing is sent) and writes one line per SPDP/SEDP
submessage: time, UDP port, vendor (0112 RustDDS, 010f Fast DDS), source and destination
GUID prefix (first and last 4 bytes), which built-in endpoint (SPDP, PW/PR = DCPSPublication
writer/reader, SW/SR = DCPSSubscription writer/reader) and the submessage: DATA with its
sequence number and the first ROS topic name in it, HEARTBEAT first..last, ACKNACK base and
the sequence numbers it asks for, GAP. With `--domain` only that domain's ports are kept.
Run it beside `discovery_probe.py` to see which announcements a participant received,
acknowledged or asked again for (docs/notes/2026-12-dds-test-forensics.md, "The 10 s failure, traced").
"""
import argparse
import re
import socket
import struct

ENDPOINTS = {b"\x00\x01\x00\xc2": "SPDP", b"\x00\x00\x03\xc2": "PW", b"\x00\x00\x03\xc7": "PR",
             b"\x00\x00\x04\xc2": "SW", b"\x00\x00\x04\xc7": "SR"}
TOPIC = re.compile(rb"(r[rqt]/[\x21-\x7e]{2,80}|ros_discovery_info)")
DATA, DATA_FRAG, HEARTBEAT, ACKNACK, GAP, INFO_DST = 0x15, 0x16, 0x07, 0x06, 0x08, 0x0E


def _sn(b, o, le):
    hi, lo = struct.unpack_from("<iI" if le else ">iI", b, o)
    return (hi << 32) | lo


def _short(prefix):
    h = prefix.hex()
    return h[:8] + h[-8:]


def submessages(rtps):
    """(kind, flags, body) of each submessage after the 20-byte RTPS header."""
    o = 20
    while o + 4 <= len(rtps):
        sid, fl = rtps[o], rtps[o + 1]
        ln = struct.unpack_from("<H" if fl & 1 else ">H", rtps, o + 2)[0]
        yield sid, fl, rtps[o + 4:o + 4 + ln] if ln else rtps[o + 4:]
        if ln == 0:
            return
        o += 4 + ln


def describe(sid, fl, body):
    """The endpoint and a short text for a discovery submessage, or None."""
    le = fl & 1
    rid, wid = (body[4:8], body[8:12]) if sid in (DATA, DATA_FRAG) else (body[0:4], body[4:8])
    ep = ENDPOINTS.get(wid) or ENDPOINTS.get(rid)
    if ep is None:
        return None
    u32 = "<I" if le else ">I"
    if sid == DATA:
        m = TOPIC.search(body)
        return ep, f"DATA sn={_sn(body, 12, le)} {m.group(0).decode(errors='replace') if m else ''}".rstrip()
    if sid == DATA_FRAG:
        return ep, f"FRAG sn={_sn(body, 12, le)}"
    if sid == HEARTBEAT:
        return ep, f"HB {_sn(body, 8, le)}..{_sn(body, 16, le)} final={fl >> 1 & 1}"
    if sid == ACKNACK:
        base, nbits = _sn(body, 8, le), struct.unpack_from(u32, body, 16)[0]
        words = [struct.unpack_from(u32, body, 20 + 4 * i)[0] for i in range((nbits + 31) // 32)]
        asked = [base + i for i in range(nbits) if words[i // 32] >> (31 - i % 32) & 1]
        return ep, f"ACKNACK base={base} asks={asked[:32]} final={fl >> 1 & 1}"
    if sid == GAP:
        return ep, f"GAP start={_sn(body, 8, le)} base={_sn(body, 16, le)}"
    return None


def main():
    import time
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--domain", type=int, help="keep only this ROS_DOMAIN_ID's ports")
    a = ap.parse_args()
    ports = range(7400 + 250 * a.domain, 7400 + 250 * (a.domain + 1)) if a.domain is not None else None
    s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.ntohs(0x0003))
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 << 20)
    s.bind(("lo", 0))
    with open(a.out, "w", buffering=1) as out:
        while True:
            pkt, addr = s.recvfrom(65535)
            # Each loopback datagram is seen twice (outgoing and incoming): keep one.
            if addr[2] == socket.PACKET_OUTGOING or pkt[12:14] != b"\x08\x00" or pkt[14 + 9] != 17:
                continue
            udp = pkt[14 + (pkt[14] & 15) * 4:]
            port, rtps = struct.unpack_from(">H", udp, 2)[0], udp[8:]
            if rtps[:4] != b"RTPS" or (ports is not None and port not in ports):
                continue
            src, dst, t = _short(rtps[8:20]), "*", time.time()
            for sid, fl, body in submessages(rtps):
                if sid == INFO_DST:
                    dst = _short(body[:12])
                    continue
                d = describe(sid, fl, body) if sid in (DATA, DATA_FRAG, HEARTBEAT, ACKNACK, GAP) else None
                if d:
                    out.write(f"{t:.4f} p{port} v{rtps[6:8].hex()} {src}->{dst} {d[0]} {d[1]}\n")


if __name__ == "__main__":
    main()
