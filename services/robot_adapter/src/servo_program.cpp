#include "dh/rtde/servo_program.hpp"

#include <cstdio>
#include <string_view>

namespace dh::rtde {
namespace {

/// "input_double_register_24" → 24
int register_index(std::string_view name) { return std::stoi(std::string(name.substr(name.rfind('_') + 1))); }

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

std::string version_line() {
  return "  # " + std::string(ServoProgram::kName) + " version " + std::to_string(ServoProgram::kVersion);
}

}  // namespace

std::string servo_program_text(const ServoProgram& p) {
  const int seq = register_index(ServoProgram::kSequenceRegister);
  const int grip = register_index(ServoProgram::kGripperRegister);
  const int applied = register_index(ServoProgram::kAppliedRegister);
  const int nonce = register_index(ServoProgram::kNonceRegister);
  const int started = register_index(ServoProgram::kStartedRegister);
  std::string pose = "p[";
  for (std::size_t i = 0; i < ServoProgram::kTargetRegisters.size(); ++i)
    pose += (i ? ", " : "") + std::string("read_input_float_register(") +
            std::to_string(register_index(ServoProgram::kTargetRegisters[i])) + ")";
  pose += "]";
  // servoj blocks for t, one controller cycle; sync() does the same while stopped.
  return "def " + std::string(ServoProgram::kName) + "():\n" + version_line() + "\n" +
         "  # DynaHarness: servo the tool to the target the adapter writes over RTDE; stop when none comes.\n"
         "  write_output_integer_register(" +
         std::to_string(applied) +
         ", 0)\n"
         "  write_output_integer_register(" +
         std::to_string(started) + ", read_input_integer_register(" + std::to_string(nonce) +
         "))\n"
         "  last = 0\n"
         "  idle = 0.0\n"
         "  moving = False\n"
         "  target = get_actual_tcp_pose()\n"
         "  ref = get_actual_joint_positions()\n"
         "  while True:\n"
         "    seq = read_input_integer_register(" +
         std::to_string(seq) +
         ")\n"
         "    if seq > 0 and seq != last:\n"
         "      target = " +
         pose +
         "\n"
         "      last = seq\n"
         "      idle = 0.0\n"
         "      moving = True\n"
         "      write_output_integer_register(" +
         std::to_string(applied) +
         ", seq)\n"
         "    end\n"
         "    set_tool_digital_out(" +
         std::to_string(p.gripper_output) + ", read_input_integer_register(" + std::to_string(grip) +
         ") == 1)\n"
         "    if moving and (seq == 0 or idle >= " +
         num(p.watchdog_s) +
         "):\n"
         "      stopj(" +
         num(p.stop_deceleration) +
         ")\n"
         "      moving = False\n"
         "      write_output_integer_register(" +
         std::to_string(applied) +
         ", 0)\n"
         "    end\n"
         "    if moving:\n"
         "      q = get_inverse_kin(target, qnear=ref)\n"
         "      i = 0\n"
         "      while i < 6:\n"
         "        d = q[i] - ref[i]\n"
         "        if d > " + num(p.joint_speed * p.timing.t_s) + ":\n"
         "          d = " + num(p.joint_speed * p.timing.t_s) + "\n"
         "        elif d < -" + num(p.joint_speed * p.timing.t_s) + ":\n"
         "          d = -" + num(p.joint_speed * p.timing.t_s) + "\n"
         "        end\n"
         "        ref[i] = ref[i] + d\n"
         "        i = i + 1\n"
         "      end\n"
         "      servoj(ref, t=" +
         num(p.timing.t_s) + ", lookahead_time=" + num(p.timing.lookahead_s) +
         ", gain=" + num(p.timing.gain) +
         ")\n"
         "      idle = idle + " +
         num(p.timing.t_s) +
         "\n"
         "    else:\n"
         "      ref = get_actual_joint_positions()\n"
         "      sync()\n"
         "    end\n"
         "  end\n"
         "end\n";
}

bool is_servo_program(const std::string& script) {
  const std::string head = "def " + std::string(ServoProgram::kName) + "():\n" + version_line() + "\n";
  return script.compare(0, head.size(), head) == 0;
}

}  // namespace dh::rtde
