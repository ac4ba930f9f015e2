%EXAMPLE_LHIFAM_WALL  Design the LHifAM's virtual wall and plot its stability boundary.
%
%   Start a server first (`zwidth serve`), then in MATLAB or GNU Octave:
%       addpath('clients/matlab'); example_lhifam_wall
%   Set ZWIDTH_URL (and ZWIDTH_API_TOKEN) to use another server.  Set the
%   variable `figure_file` before running to save the figure instead of showing it.

device = struct('preset', 'lhifam', 'delay', 1e-3);        % chapter Table 2, with 1 ms of loop delay

design = zwidth_design_stiffness(device, struct('min_gain_margin_db', 6));
if ~strcmp(design.status, 'optimal')
  error('example:design', 'no safe wall: %s', design.reason);
end
fprintf('LHifAM wall (1 ms delay): K = %.1f N/m, B = %.2f N*s/m, K_cr = %.1f N/m, margin %.2f dB\n', ...
        design.stiffness, design.damping, design.critical_stiffness, design.gain_margin_db);

check = zwidth_analyze(device, struct('stiffness', design.stiffness, 'damping', design.damping));
fprintf('independent check: stable = %d, gain margin %.2f dB\n', check.stable, check.gain_margin_db);

b = zwidth_boundary(device, struct('points', 60));
B = [b.points.damping];
K = [b.points.critical_stiffness];

if exist('figure_file', 'var'), fig = figure('visible', 'off'); else, fig = figure(); end
plot(B, K, 'b-', 'LineWidth', 1.5); hold on;
plot(design.damping, design.stiffness, 'ro', 'MarkerFaceColor', 'r');
plot(b.optimum.damping, b.optimum.critical_stiffness, 'k^');
xlabel('virtual damping B [N s/m]'); ylabel('critical stiffness K_{cr} [N/m]');
legend('stability boundary K_{cr}(B)', 'designed wall (6 dB)', 'stiffest stable wall', 'Location', 'best');
title('LHifAM with 1 ms delay'); grid on;
if exist('figure_file', 'var')
  % SVG by suffix; PNG through cairo under Octave's gnuplot toolkit (its plain -dpng needs Ghostscript)
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
