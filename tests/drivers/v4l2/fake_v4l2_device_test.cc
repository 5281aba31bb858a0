// The fake node keeps the kernel's rules, so capture code that breaks them fails on the desk as it would on a robot.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/mman.h>

#include <cerrno>

#include "drivers/v4l2/fake_v4l2_device.h"
#include "tests/drivers/v4l2/fake_setup.h"

namespace qsg::testing {
namespace {

using v4l2::FakeV4l2Device;

v4l2_buffer mmap_buffer(std::uint32_t index) {
  v4l2_buffer b{};
  b.index = index;
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  return b;
}

TEST(FakeV4l2Device, EnforcesTheStreamingStateMachine) {
  FakeV4l2Device fake(small_colour_node());
  EXPECT_EQ(fake.sys_open("/dev/video5", O_RDWR), -ENOENT);
  const int fd = fake.sys_open("/dev/video0", O_RDWR | O_NONBLOCK);
  ASSERT_GE(fd, 0);
  EXPECT_EQ(fake.sys_open("/dev/video0", O_RDWR), -EBUSY) << "one owner at a time";
  EXPECT_EQ(fake.sys_ioctl(fd + 1, VIDIOC_QUERYCAP, nullptr), -EBADF);

  v4l2_buffer b = mmap_buffer(0);
  EXPECT_EQ(fake.sys_ioctl(fd, VIDIOC_QBUF, &b), -EINVAL) << "QBUF before REQBUFS";
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  EXPECT_EQ(fake.sys_ioctl(fd, VIDIOC_STREAMON, &type), -EINVAL) << "STREAMON without buffers";

  v4l2_requestbuffers req{};
  req.count = 3;
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_USERPTR;
  EXPECT_EQ(fake.sys_ioctl(fd, VIDIOC_REQBUFS, &req), -EINVAL) << "only MMAP";
  req.memory = V4L2_MEMORY_MMAP;
  ASSERT_EQ(fake.sys_ioctl(fd, VIDIOC_REQBUFS, &req), 0);
  EXPECT_EQ(req.count, 3u);

  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  EXPECT_EQ(fake.sys_ioctl(fd, VIDIOC_S_FMT, &fmt), -EBUSY) << "format is fixed while buffers exist";

  int error = 0;
  EXPECT_EQ(fake.sys_mmap(100, PROT_READ, MAP_SHARED, fd, 12345, &error), nullptr);
  EXPECT_EQ(error, EINVAL) << "offsets come from QUERYBUF";
  b = mmap_buffer(1);
  ASSERT_EQ(fake.sys_ioctl(fd, VIDIOC_QUERYBUF, &b), 0);
  void* p = fake.sys_mmap(b.length, PROT_READ, MAP_SHARED, fd, b.m.offset, &error);
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(fake.live_mappings(), 1);
  req.count = 0;
  EXPECT_EQ(fake.sys_ioctl(fd, VIDIOC_REQBUFS, &req), -EBUSY) << "buffers are mapped";

  ASSERT_EQ(fake.sys_ioctl(fd, VIDIOC_QBUF, &b), 0);
  EXPECT_EQ(fake.sys_ioctl(fd, VIDIOC_QBUF, &b), -EINVAL) << "queued twice";
  v4l2_buffer d = mmap_buffer(0);
  EXPECT_EQ(fake.sys_ioctl(fd, VIDIOC_DQBUF, &d), -EINVAL) << "DQBUF while not streaming";
  fake.push_frames(1);
  ASSERT_EQ(fake.sys_ioctl(fd, VIDIOC_STREAMON, &type), 0);
  short revents = 0;
  EXPECT_EQ(fake.sys_poll(fd, POLLIN, 10, &revents), 1);
  EXPECT_TRUE(revents & POLLIN);
  ASSERT_EQ(fake.sys_ioctl(fd, VIDIOC_DQBUF, &d), 0);
  EXPECT_EQ(d.index, 1u);
  EXPECT_EQ(d.sequence, 0u);
  EXPECT_EQ(fake.sys_ioctl(fd, VIDIOC_DQBUF, &d), -EAGAIN) << "nothing more done";
  EXPECT_EQ(fake.sys_ioctl(fd, 0x12345678ul, &d), -ENOTTY);

  EXPECT_EQ(fake.sys_close(fd), 0);
  EXPECT_EQ(fake.live_mappings(), 1) << "a mapping outlives its file";
  EXPECT_EQ(fake.sys_munmap(p, b.length), 0);
  EXPECT_EQ(fake.live_mappings(), 0);
  EXPECT_EQ(fake.sys_munmap(p, b.length), -EINVAL);
}

TEST(FakeV4l2Device, NegotiatesLikeADriver) {
  FakeV4l2Device fake(small_colour_node());
  const int fd = fake.sys_open("/dev/video0", O_RDWR);
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.pixelformat = V4L2_PIX_FMT_Z16;
  fmt.fmt.pix.width = 300;
  fmt.fmt.pix.height = 200;
  ASSERT_EQ(fake.sys_ioctl(fd, VIDIOC_S_FMT, &fmt), 0);
  EXPECT_EQ(fmt.fmt.pix.pixelformat, static_cast<std::uint32_t>(V4L2_PIX_FMT_YUYV)) << "unknown format: the first";
  EXPECT_EQ(fmt.fmt.pix.width, 320u) << "nearest size";
  EXPECT_EQ(fmt.fmt.pix.bytesperline, 640u);
  v4l2_fmtdesc desc{};
  desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  int formats = 0;
  for (desc.index = 0; fake.sys_ioctl(fd, VIDIOC_ENUM_FMT, &desc) == 0; ++desc.index) ++formats;
  EXPECT_EQ(formats, 2) << "YUYV and RGB3, each listed once";
}

}  // namespace
}  // namespace qsg::testing
