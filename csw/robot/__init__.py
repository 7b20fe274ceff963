"""Robot logs in (ROS 1 and 2 bags, MCAP, KITTI raw drives, live side-by-side streams:
csw.robot.logs) and robot messages out (DisparityImage, PointCloud2: csw.robot.bags).
Above csw.camera: a log's raw frames are rectified with the rig its CameraInfos give."""
