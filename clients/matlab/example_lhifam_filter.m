%EXAMPLE_LHIFAM_FILTER  The LHifAM's wall with a 50 Hz first-order velocity filter and a virtual mass.
%
%   Start a server first (`zwidth serve`), then in MATLAB or GNU Octave:
%       addpath('clients/matlab'); example_lhifam_filter
%   Set ZWIDTH_URL (and ZWIDTH_API_TOKEN) to use another server.  Set the
%   variable `figure_file` before running to save the figure instead of showing it.
%
%   The damper of most labs' walls acts on a filtered velocity: the filter's lag
%   lowers K_cr(B) (docs/virtual_environment.md).  This script analyses one wall
%   with and without the filter, prints the stable range of the virtual mass
%   (the M-width) and overlays the two stability boundaries.

device = struct('mass', 5.4, 'damping', 3.5, 'sample_time', 1e-3);   % the rigid LHifAM (chapter Table 2)
lowpass = struct('kind', 'low_pass', 'cutoff_hz', 50, 'order', 1);
wall = struct('stiffness', 2e4, 'damping', 50, 'mass', 0.5);

plain = zwidth_analyze(device, wall);
wall.velocity_filter = lowpass;
filtered = zwidth_analyze(device, wall);
fprintf('backward difference: K_cr = %.1f N/m, B_max = %.1f N*s/m, M-width [%.4g, %.4g] kg\n', ...
        plain.critical_stiffness, plain.max_stable_damping, plain.mass_range.min, plain.mass_range.max);
fprintf('low-pass 50 Hz:      K_cr = %.1f N/m, B_max = %.1f N*s/m, M-width [%.4g, %.4g] kg\n', ...
        filtered.critical_stiffness, filtered.max_stable_damping, filtered.mass_range.min, filtered.mass_range.max);
fprintf('passive: %d (b must exceed %.4g N*s/m)\n', filtered.passive, filtered.passivity_required_damping);

b0 = zwidth_boundary(device, struct('points', 60));
b1 = zwidth_boundary(device, struct('points', 60, 'controller', struct('velocity_filter', lowpass)));
fprintf('best K_cr: %.1f N/m at B = %.1f (backward difference), %.1f N/m at B = %.1f (50 Hz)\n', ...
        b0.optimum.critical_stiffness, b0.optimum.damping, b1.optimum.critical_stiffness, b1.optimum.damping);

if exist('figure_file', 'var'), fig = figure('visible', 'off'); else, fig = figure(); end
semilogy([b0.points.damping], [b0.points.critical_stiffness], 'b-', 'LineWidth', 1.5); hold on;
semilogy([b1.points.damping], [b1.points.critical_stiffness], 'r-', 'LineWidth', 1.5);
xlabel('virtual damping B [N s/m]'); ylabel('critical stiffness K_{cr} [N/m]');
legend('backward difference', 'low-pass 50 Hz, first order', 'Location', 'best');
title('LHifAM (rigid): the boundary with a velocity filter'); grid on;
if exist('figure_file', 'var')
  if numel(figure_file) > 4 && strcmpi(figure_file(end-3:end), '.svg')
    device_flag = '-dsvg';
  elseif exist('OCTAVE_VERSION', 'builtin') && strcmp(graphics_toolkit(), 'gnuplot')
    device_flag = '-dpngcairo';
  else
    device_flag = '-dpng';
  end
  print(fig, figure_file, device_flag);
  fprintf('wrote %s\n', figure_file);
end
