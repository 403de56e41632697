// The servo program's text says what servo_program.hpp declares: the registers, the timing, the
// watchdog, the gripper output; a controller recognises it by its first two lines and nothing else.
#include <gtest/gtest.h>

#include <sstream>

#include "dh/rtde/servo_program.hpp"

namespace dh::rtde {
namespace {

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(ServoProgram, ReadsTheDeclaredRegistersAndServosWithTheDeclaredTiming) {
  ServoProgram p;
  p.timing = {0.002, 0.05, 500};
  p.watchdog_s = 0.15;
  p.gripper_output = 1;
  const std::string text = servo_program_text(p);
  EXPECT_EQ(text.rfind("def dh_servo():\n  # dh_servo version 2\n", 0), 0u) << text;
  EXPECT_TRUE(has(text, "seq = read_input_integer_register(24)"));
  EXPECT_TRUE(has(text,
                  "p[read_input_float_register(24), read_input_float_register(25), "
                  "read_input_float_register(26), read_input_float_register(27), "
                  "read_input_float_register(28), read_input_float_register(29)]"));
  EXPECT_TRUE(has(text, "write_output_integer_register(24, seq)"));
  EXPECT_TRUE(has(text, "set_tool_digital_out(1, read_input_integer_register(25) == 1)"));
  EXPECT_TRUE(has(text, "q = get_inverse_kin(target, qnear=ref)"));
  // Each joint's reference steps towards the solution at 1.5 rad/s at most: 0.003 rad per 2 ms cycle.
  EXPECT_TRUE(has(text, "if d > 0.003:\n          d = 0.003\n        elif d < -0.003:\n          d = -0.003\n"));
  EXPECT_TRUE(has(text, "servoj(ref, t=0.002, lookahead_time=0.05, gain=500)"));
  EXPECT_TRUE(has(text, "idle >= 0.15"));
  EXPECT_TRUE(has(text, "stopj(4)"));
  // Every block is closed: as many `end` lines as openers.
  std::size_t ends = 0, openers = 0;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    const std::string word = line.substr(line.find_first_not_of(' '));
    ends += word == "end";
    openers += word.starts_with("def ") || word.starts_with("if ") || word.starts_with("while ");
  }
  EXPECT_EQ(ends, openers);
  EXPECT_TRUE(has(text, "write_output_integer_register(25, read_input_integer_register(26))"));
  // One def block, which the controller runs when received: nothing after its end.
  EXPECT_TRUE(text.ends_with("    end\n  end\nend\n"));
}

TEST(ServoProgram, IsRecognisedByItsNameAndVersionOnly) {
  EXPECT_TRUE(is_servo_program(servo_program_text({})));
  EXPECT_FALSE(is_servo_program("def dh_servo():\n  # dh_servo version 1\n"));
  EXPECT_FALSE(is_servo_program("def other():\n  # dh_servo version 1\n"));
  EXPECT_FALSE(is_servo_program(""));
}

}  // namespace
}  // namespace dh::rtde
