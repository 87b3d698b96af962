!> The flat interface's input design (report sec. VII-VIII): the
!> operator's and the Riccati method's mu and length, optimal, amplitude-
!> limited and equalised inputs, their information and responses.
!> Conventions: mlid_api_deck's comment.
module mlid_api_design
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_int64_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan, ieee_value, ieee_quiet_nan
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_design, only: design_t, design_create, operator_mu, riccati_length, transition_length, &
                         costate_input, input_information, mu_for_length, &
                         amplitude_limited_input, equalised_input
  use mlid_design, only: design_state_penalty, input_response, RICCATI_BRACKET
  implicit none
  private
  public :: mlid_design_mu, mlid_design_length, mlid_design_input, mlid_design_information, &
            mlid_design_amplitude, mlid_design_mu_for_length, mlid_design_response, &
            mlid_design_equalised

contains

  !> Input design (mlid_design).  Common arguments: the linear model F(nx,nx),
  !> G(nx,nu), H(ny,nx), the noise spectral density R(ny,ny), the process
  !> noise Gamma Q Gamma' gq(nx,nx) (zero: none), the m unknowns
  !> by block ukind (1 F, 2 G, 3 H), row urow and column ucol, weights w(m).
  !> mu_max on [0, T] by the operator method on ncell and 2 ncell cells; u:
  !> the optimal input on the 2 ncell cells (unit energy, nu per cell).
  !> kx(nx,nx), symmetric >= 0, the state-limit penalty of report 7.6 (mu the
  !> largest eigenvalue of tr(WM) - int x' K x dt); zero for none.
  subroutine mlid_design_mu(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w, kx, t, ncell, mu, &
                            u, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, ncell
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), w(m), &
                                  kx(nx, nx), t
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: mu, u(2*ncell*nu)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    mu = 0.0_wp
    u = 0.0_wp
    call design_with_penalty(f, g, h, r, gq, ukind, urow, ucol, w, kx, d, status, msg)
    if (status == MLID_OK) call operator_mu(d, t, ncell, mu, u, status, msg)
    if (status /= MLID_OK .and. mu <= 0.0_wp .and. any(kx /= 0.0_wp) .and. &
        index(msg, 'do not affect') > 0) then
      msg = 'the state penalty outweighs the information of every input: lower its weight'
    end if
  end subroutine mlid_design_mu

  !> The critical length T of mu (method 1 Riccati, 2 transition matrix),
  !> searched up to tmax; lam0(na), na = (m+1) nx: the costate lambda(0)
  !> (transition method only); kx the state penalty as in mlid_design_mu.
  subroutine mlid_design_length(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w, kx, mu, tmax, &
                                method, na, t, lam0, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, method, na
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), w(m), &
                                  kx(nx, nx), mu, tmax
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: t, lam0(na)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    t = 0.0_wp
    lam0 = 0.0_wp
    call design_with_penalty(f, g, h, r, gq, ukind, urow, ucol, w, kx, d, status, msg)
    if (status /= MLID_OK) return
    if (na /= d%na) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0)') 'lam0 needs (m+1) nx = ', d%na
      return
    end if
    if (method == 1) then
      call riccati_length(d, mu, tmax, t, status, msg)
    else if (method == 2) then
      call transition_length(d, mu, tmax, t, lam0, status, msg)
    else
      status = MLID_ERR_INPUT
      msg = 'method must be 1 (Riccati) or 2 (transition matrix)'
    end if
  end subroutine mlid_design_length

  !> The optimal input from the costate lam0 (transition method) on ncell
  !> cells of [0, T], unit energy.
  subroutine mlid_design_input(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w, mu, t, na, &
                               lam0, ncell, u, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, na, ncell
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), w(m), mu, t
    real(c_double), intent(in) :: lam0(na)
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: u(ncell*nu)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    u = 0.0_wp
    call design_create(f, g, h, r, ukind, urow, ucol, w, d, status, msg, gq)
    if (status /= MLID_OK) return
    if (na /= d%na) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0)') 'lam0 needs (m+1) nx = ', d%na
      return
    end if
    call costate_input(d, mu, t, lam0, ncell, u, status, msg)
  end subroutine mlid_design_input

  !> The information matrix mm(m, m) (unweighted, eq. 7.12) of the input u
  !> held over ncell cells of [0, T] (nu per cell).
  subroutine mlid_design_information(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, t, ncell, u, &
                                     mm, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, ncell
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), t, u(ncell*nu)
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: mm(m, m)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    real(wp) :: ones(m)
    mm = 0.0_wp
    ones = 1.0_wp
    if (.not. all(ieee_is_finite(u))) then
      status = MLID_ERR_INPUT
      msg = 'input is not finite'
      return
    end if
    call design_create(f, g, h, r, ukind, urow, ucol, ones, d, status, msg, gq)
    if (status == MLID_OK) call input_information(d, t, ncell, u, mm, status, msg)
  end subroutine mlid_design_information

  !> The best square wave |u| = peak held over ncell cells of [0, T]
  !> (mlid_design amplitude_limited_input); trwm its weighted trace.
  subroutine mlid_design_amplitude(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w, t, &
                                   ncell, peak, u, trwm, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, ncell
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), &
                                  w(m), t, peak
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: u(ncell*nu), trwm
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    u = 0.0_wp
    trwm = 0.0_wp
    call design_create(f, g, h, r, ukind, urow, ucol, w, d, status, msg, gq)
    if (status == MLID_OK) call amplitude_limited_input(d, t, ncell, peak, u, trwm, status, msg)
  end subroutine mlid_design_amplitude

  !> mu_max for the length td by the secant iteration of eq. 7.89 on the
  !> Riccati critical length, started within RICCATI_BRACKET of mu0 (the operator's).
  subroutine mlid_design_mu_for_length(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w, td, &
                                       mu0, mu, status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), w(m), td, mu0
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: mu
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    type(design_t) :: d
    mu = 0.0_wp
    call design_create(f, g, h, r, ukind, urow, ucol, w, d, status, msg, gq)
    if (status == MLID_OK) call mu_for_length(d, td, (1.0_wp - RICCATI_BRACKET)*mu0, &
                                              (1.0_wp + RICCATI_BRACKET)*mu0, mu, status, msg)
  end subroutine mlid_design_mu_for_length

  !> The states x(nx, 0:ncell ns) of x' = F x + G u, x(0) = 0, under the input
  !> u held over ncell cells of [0, T], at ns substeps per cell.
  subroutine mlid_design_response(nx, nu, f, g, t, ncell, ns, u, x, status, msg)
    integer(c_int), intent(in) :: nx, nu, ncell, ns
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), t, u(ncell*nu)
    real(c_double), intent(out) :: x(nx, ncell*ns + 1)
    integer(c_int), intent(out) :: status
    character(len=256), intent(out) :: msg
    x = 0.0_wp
    if (.not. (all(ieee_is_finite(u)) .and. all(ieee_is_finite(f)) .and. &
               all(ieee_is_finite(g)))) then
      status = MLID_ERR_INPUT
      msg = 'F, G and the input must be finite'
      return
    end if
    call input_response(f, g, t, ncell, ns, u, x, status, msg)
  end subroutine mlid_design_response

  !> The weighted-trace design of report 7.8 (mlid_design equalised_input): from
  !> weights w0, at most iterations updates of eq. 7.88 from step alpha; w
  !> the weights kept, u the input on 2 ncell cells (energy e, nu per
  !> cell), mu, mm its unweighted information, ratios(1:nratio) the
  !> diag(WM) max/min of each design kept.
  subroutine mlid_design_equalised(nx, nu, ny, f, g, h, r, gq, m, ukind, urow, ucol, w0, t, &
                                   ncell, e, iterations, alpha, w, u, mu, mm, ratios, nratio, &
                                   status, msg)
    integer(c_int), intent(in) :: nx, nu, ny, m, ncell, iterations
    real(c_double), intent(in) :: f(nx, nx), g(nx, nu), h(ny, nx), r(ny, ny), gq(nx, nx), &
                                  w0(m), t, e, alpha
    integer(c_int), intent(in) :: ukind(m), urow(m), ucol(m)
    real(c_double), intent(out) :: w(m), u(2*ncell*nu), mu, mm(m, m), ratios(iterations + 1)
    integer(c_int), intent(out) :: nratio, status
    character(len=256), intent(out) :: msg
    call equalised_input(f, g, h, r, gq, ukind, urow, ucol, w0, t, ncell, e, iterations, alpha, &
                         w, u, mu, mm, ratios, nratio, status, msg)
  end subroutine mlid_design_equalised

  !> The design problem, with the state-limit penalty kx(nx,nx) of report
  !> 7.6 when kx is not zero (a zero kx is no penalty: the plain design).
  subroutine design_with_penalty(f, g, h, r, gq, ukind, urow, ucol, w, kx, d, status, msg)
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), r(:, :), gq(:, :), w(:), kx(:, :)
    integer(c_int), intent(in) :: ukind(:), urow(:), ucol(:)
    type(design_t), intent(out) :: d
    integer(c_int), intent(out) :: status
    character(len=*), intent(out) :: msg
    call design_create(f, g, h, r, ukind, urow, ucol, w, d, status, msg, gq)
    if (status == MLID_OK .and. any(kx /= 0.0_wp)) call design_state_penalty(d, kx, status, msg)
  end subroutine design_with_penalty

end module mlid_api_design
