#!/usr/bin/env python3
"""Counts the DDS discovery multicast frames (UDP to 239.255.0.1, RTPS's default SPDP group) seen on one
interface until SIGTERM, then prints the count. Run in the test hosts' switch namespace on its bridge:
    deploy/testhosts run PREFIX switch tests/system/count_dds_multicast.py br0
"""
import signal
import socket
import sys

ETH_P_ALL = 0x0003
SPDP_GROUP = socket.inet_aton("239.255.0.1")

count = 0


def stop(*_):
    print(count, flush=True)
    sys.exit(0)


signal.signal(signal.SIGTERM, stop)
signal.signal(signal.SIGINT, stop)
sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.ntohs(ETH_P_ALL))
sock.bind((sys.argv[1], 0))
print("listening", flush=True)
while True:
    frame = sock.recv(65535)
    # Ethernet II, IPv4 (0x0800), protocol UDP (17), destination address at IP offset 16.
    if len(frame) >= 34 and frame[12:14] == b"\x08\x00" and frame[23] == 17 and frame[30:34] == SPDP_GROUP:
        count += 1
