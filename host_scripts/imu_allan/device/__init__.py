"""The device layer: bytes from the board (or its simulator) into typed records.

framing.py  the CRC-16 and both frame formats (text lines, binary sample frames)
records.py  the protocol's records (B H L S E C ok error) and whole device reports
stream.py   the one stream decoder of mixed captures (lines, raw rows, frames)
capture.py  a capture decoded once; files.py the one way a file is read
link.py     the serial port: open and lock it, one command and its reply
simrun.py   imu-sim as a child process
"""
