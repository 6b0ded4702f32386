"""The sources layer: every input format, read into samples (and device reports).

detect.py  what a file is (by content) and the reader that fits; options checked against it
source.py  SampleSource and Source: what every reader hands the statistics
rows.py    the thesis rows file (one sample a line): its reader and its writer
table.py   delimited text with a header (CSV, EuRoC, Kalibr, rostopic echo -p, one column)
rosbag.py  ROS 1 and ROS 2 bags: sensor_msgs/Imu messages (rosbags, and the two below)
bagdb3.py  a ROS 2 sqlite3 bag's messages in bulk, straight from sqlite
bagmcap.py a ROS 2 MCAP bag's messages chunk by chunk, found as arrays
bagros1.py a ROS 1 bag's messages chunk by chunk, through its own index
imumsg.py  sensor_msgs/Imu bytes (ROS 1, CDR) decoded as arrays
arrays.py  NumPy .npy and .npz arrays
timing.py  a time column's or stamps' rate and gaps
"""
